#include "ros2_node.hpp"

#include <chrono>
#include <cstdio>

#include "dds_conversions.hpp"
#include "std_msgs.h"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

const std::vector<std::string> kOwnParameters = {"use_sim_time", "cloud_reliability"};

RosArguments with_ros2_naming(RosArguments a) {
  a.parameters.prefix = "";
  a.parameters.separator = '.';
  return a;
}

// The node's own settings, the point topics' names resolved once: a bad name stops the node as a bad value does.
node::NodeSettings checked_settings(const RosArguments& arguments, const NameResolver& names) {
  node::NodeSettings s =
      node::settings_from(arguments.parameters, node::default_last_pose_file(arguments.node.fully_qualified()));
  for (const std::string& t : s.point_topics) names.resolve(t);
  return s;
}

}  // namespace

Ros2Settings ros2_settings_from(const node::NodeParameters& p) {
  Ros2Settings s;
  if (const auto it = p.values.find("use_sim_time"); it != p.values.end()) {
    const std::string& v = it->second.text;
    if (v != "true" && v != "false" && v != "True" && v != "False") {
      throw Error("use_sim_time must be true or false, got '" + one_line(v) + "'");
    }
    s.use_sim_time = v == "true" || v == "True";
  }
  if (const auto it = p.values.find("cloud_reliability"); it != p.values.end()) {
    const std::string& v = it->second.text;
    if (v != "best_effort" && v != "reliable") {
      throw Error("cloud_reliability must be best_effort or reliable, got '" + one_line(v) + "'");
    }
    s.reliable_clouds = v == "reliable";
  }
  return s;
}

Ros2Node::Ros2Node(const RosArguments& arguments, const DomainConfig& domain)
    : arguments_(with_ros2_naming(arguments)),
      names_(arguments.node, arguments.remaps),
      ros2_(ros2_settings_from(arguments_.parameters)),
      // Every parameter is checked before the node joins the domain: a bad start sends nothing.
      settings_(checked_settings(arguments_, names_)),
      options_(node::localizer_options_of(arguments_.parameters)),
      participant_(domain),
      pose_(participant_.handle(), geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, topic("amcl_pose"),
            latched_qos(1)),
      particles_(participant_.handle(), nav2_msgs_msg_dds__ParticleCloud__desc, topic("particle_cloud"),
                 sensor_data_qos()),
      hypotheses_(participant_.handle(), nav2_msgs_msg_dds__ParticleCloud__desc, topic("~/hypotheses"),
                  reliable_qos(1)),
      diagnostics_(participant_.handle(), diagnostic_msgs_msg_dds__DiagnosticArray__desc, topic("/diagnostics"),
                   reliable_qos(10)),
      tf_(participant_.handle(), tf2_msgs_msg_dds__TFMessage__desc, topic("/tf"), reliable_qos(100)),
      map_cloud_(participant_.handle(), sensor_msgs_msg_dds__PointCloud2__desc, topic("~/map_cloud"), latched_qos(1)) {
  for (const std::string& w : node::unknown_parameter_warnings(arguments_.parameters, kOwnParameters)) {
    log(node::LogLevel::kWarn, "tsdf_mcl: " + w + " (see tsdf-mcl localize --help and docs/ros2.md)");
  }
  for (const std::string& n : arguments_.notes) log(node::LogLevel::kInfo, "tsdf_mcl: " + n);
  log(node::LogLevel::kInfo, "tsdf_mcl: " + arguments_.node.fully_qualified() + " in DDS " + domain.described +
                                 (ros2_.use_sim_time ? ", sim time from /clock" : ""));
  core_ = std::make_unique<node::LocalizationCore>(settings_, options_, *this);
  subscribe();
}

Ros2Node::~Ros2Node() {
  // The loops first (their threads call into the core), then the core (it logs through this object as it keeps the
  // last pose).
  tf_loop_.reset();
  message_loop_.reset();
  core_.reset();
}

void Ros2Node::subscribe() {
  const dds_entity_t pp = participant_.handle();
  const node::NodeSettings& s = core_->settings();
  const auto reader = [&](const dds_topic_descriptor_t& type, const std::string& name, const Qos& qos) -> Reader& {
    readers_.push_back(std::make_unique<Reader>(pp, type, topic(name), qos));
    return *readers_.back();
  };
  const auto on_error = [this](const std::string& what) { log(node::LogLevel::kError, "tsdf_mcl: " + what); };
  tf_loop_ = std::make_unique<MessageLoop>(pp, on_error);
  message_loop_ = std::make_unique<MessageLoop>(pp, on_error);
  node::LocalizationCore& core = *core_;
  tf_loop_->add(reader(tf2_msgs_msg_dds__TFMessage__desc, "/tf", reliable_qos(100)), [&core](const Sample& m) {
    core.on_tf(transforms_of(*static_cast<const tf2_msgs_msg_dds__TFMessage_*>(m.get())), false);
  });
  tf_loop_->add(reader(tf2_msgs_msg_dds__TFMessage__desc, "/tf_static", latched_qos(100)), [&core](const Sample& m) {
    core.on_tf(transforms_of(*static_cast<const tf2_msgs_msg_dds__TFMessage_*>(m.get())), true);
  });
  if (ros2_.use_sim_time) {
    // rclcpp's ClockQoS: best effort, the latest only.
    tf_loop_->add(reader(rosgraph_msgs_msg_dds__Clock__desc, "/clock", {false, false, 1, ""}), [this](const Sample& m) {
      const auto& clock = *static_cast<const rosgraph_msgs_msg_dds__Clock_*>(m.get());
      const node::RawStamp t = raw_stamp(clock.clock);
      if (t.sec < 0 || t.nanosec >= 1000000000u) return;  // a clock no time can be read from is no clock
      {
        std::lock_guard<std::mutex> lock(clock_mutex_);
        sim_time_ = node::Stamp{t.sec * 1000000000 + t.nanosec};
      }
      core_->on_clock();
    });
  }
  const Qos clouds = ros2_.reliable_clouds ? Qos{true, false, 5, ""} : sensor_data_qos();
  for (std::size_t i = 0; i < s.point_topics.size(); ++i) {
    message_loop_->add(reader(sensor_msgs_msg_dds__PointCloud2__desc, s.point_topics[i], clouds),
                       [&core, i](const Sample& m) { core.on_cloud(i, cloud_of(m)); });
  }
  if (!s.odom_topic.empty()) {
    message_loop_->add(reader(nav_msgs_msg_dds__Odometry__desc, s.odom_topic, sensor_data_qos()),
                       [&core](const Sample& m) {
                         core.on_odometry(odometry_of(*static_cast<const nav_msgs_msg_dds__Odometry_*>(m.get())));
                       });
  }
  if (!s.imu_topic.empty()) {
    message_loop_->add(
        reader(sensor_msgs_msg_dds__Imu__desc, s.imu_topic, sensor_data_qos()),
        [&core](const Sample& m) { core.on_imu(imu_of(*static_cast<const sensor_msgs_msg_dds__Imu_*>(m.get()))); });
  }
  message_loop_->add(reader(geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "initialpose", reliable_qos(5)),
                     [&core](const Sample& m) {
                       core.on_initial_pose(initial_pose_of(
                           *static_cast<const geometry_msgs_msg_dds__PoseWithCovarianceStamped_*>(m.get())));
                     });
  message_loop_->add(reader(std_msgs_msg_dds__Empty__desc, "~/reinitialize_global_localization", reliable_qos(1)),
                     [&core](const Sample&) { core.request_global_localization(); });
  services_.push_back(std::make_unique<EmptyService>(pp, names_.resolve("reinitialize_global_localization"),
                                                     [&core] { core.request_global_localization(); }));
  services_.push_back(std::make_unique<EmptyService>(pp, names_.resolve("request_nomotion_update"),
                                                     [&core] { core.request_nomotion_update(); }));
  for (const auto& service : services_) service->attach(*message_loop_);
  tf_loop_->start();
  message_loop_->start();
}

void Ros2Node::run(const std::function<bool()>& ok) { core_->run(ok); }

void Ros2Node::publish_pose(const node::PoseOut& pose) {
  const PoseMessage m(pose);
  pose_.write(&m.msg);
}

bool Ros2Node::particles_wanted() { return particles_.matched() > 0; }

void Ros2Node::publish_particles(const node::PosesOut& particles) {
  const ParticleCloudMessage m(particles);
  particles_.write(&m.msg);
}

void Ros2Node::publish_hypotheses(const node::PosesOut& hypotheses) {
  const ParticleCloudMessage m(hypotheses);
  hypotheses_.write(&m.msg);
}

void Ros2Node::publish_diagnostics(const node::DiagnosticOut& status) {
  const DiagnosticMessage m(status);
  diagnostics_.write(&m.msg);
}

void Ros2Node::send_transform(const node::TransformOut& transform) {
  const TransformMessage m(transform);
  tf_.write(&m.msg);
}

void Ros2Node::publish_map_cloud(const node::CloudOut& cloud) {
  const CloudMessage m(cloud);
  map_cloud_.write(&m.msg);
}

std::optional<node::Stamp> Ros2Node::now() {
  std::lock_guard<std::mutex> lock(clock_mutex_);
  return sim_time_;  // set only under use_sim_time
}

void Ros2Node::log(node::LogLevel level, const std::string& text) {
  // rclcpp's console format: [LEVEL] [wall time] [node name]: message.
  const char* names[] = {"INFO", "WARN", "ERROR"};
  const double wall = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  std::string message = text.rfind("tsdf_mcl: ", 0) == 0 ? text.substr(10) : text;
  std::lock_guard<std::mutex> lock(log_mutex_);
  std::fprintf(stderr, "[%s] [%.9f] [%s]: %s\n", names[static_cast<int>(level)], wall, arguments_.node.name.c_str(),
               one_line(message).c_str());
  std::fflush(stderr);
}

std::string Ros2Node::parameter_name(const std::string& name) { return name; }

std::string Ros2Node::static_transform_command(const std::string& parent, const std::string& child) {
  return "ros2 run tf2_ros static_transform_publisher --x X --y Y --z Z --yaw YAW --pitch PITCH --roll ROLL "
         "--frame-id " +
         parent + " --child-frame-id " + child;
}

}  // namespace tsdf_mcl::ros2_node
