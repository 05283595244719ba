#include "dds_link.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <fstream>

#include "dds_conversions.hpp"
#include "message_checks.hpp"
#include "ros_names.hpp"
#include "std_msgs.h"
#include "std_srvs.h"

namespace tsdf_mcl::ros2_node::test {
namespace {

constexpr int kFirstDomain = 100, kDomains = 100;

char* text(const std::string& s) { return const_cast<char*>(s.c_str()); }

builtin_interfaces_msg_dds__Time_ time_of(const node::RawStamp& t) {
  return {static_cast<std::int32_t>(t.sec), t.nanosec};
}

geometry_msgs_msg_dds__Pose_ pose_of(const node::RawPose& p) {
  const Eigen::Vector4d& q = p.orientation;
  return {{p.position.x(), p.position.y(), p.position.z()}, {q[0], q[1], q[2], q[3]}};
}

node::Stamp stamp_of(const builtin_interfaces_msg_dds__Time_& t) { return node::to_stamp(raw_stamp(t)); }

bool process_alive(pid_t pid) { return pid > 0 && (kill(pid, 0) == 0 || errno != ESRCH); }

}  // namespace

DomainClaim::DomainClaim() {
  const int start = static_cast<int>(getpid() % kDomains);
  for (int k = 0; k < kDomains && id_ < 0; ++k) {
    const int id = kFirstDomain + (start + k) % kDomains;
    const fs::path lock = fs::temp_directory_path() / ("tsdf_mcl_dds_domain_" + std::to_string(id) + ".lock");
    int fd = open(lock.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (fd < 0) {
      pid_t owner = 0;
      std::ifstream(lock) >> owner;
      if (process_alive(owner)) continue;
      fs::remove(lock);  // its owner died
      fd = open(lock.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
      if (fd < 0) continue;
    }
    const std::string pid = std::to_string(getpid());
    if (write(fd, pid.data(), pid.size()) != static_cast<ssize_t>(pid.size())) ADD_FAILURE() << "cannot write " << lock;
    close(fd);
    id_ = id;
    lock_ = lock;
  }
  if (id_ < 0) {
    ADD_FAILURE() << "no free DDS domain id in " << kFirstDomain << ".." << kFirstDomain + kDomains - 1;
    id_ = kFirstDomain;
  }
  setenv("ROS_DOMAIN_ID", std::to_string(id_).c_str(), 1);
  setenv("ROS_LOCALHOST_ONLY", "1", 1);
  unsetenv("ROS_AUTOMATIC_DISCOVERY_RANGE");
  unsetenv("CYCLONEDDS_URI");
}

DomainClaim::~DomainClaim() {
  if (!lock_.empty()) fs::remove(lock_);
}

DdsLink::DdsLink(node::test::Child& node, double transform_tolerance)
    : node_(node),
      heard_(transform_tolerance),
      participant_(domain_from_environment()),
      points_(participant(), sensor_msgs_msg_dds__PointCloud2__desc, "rt/points", reliable_qos(50)),
      odom_(participant(), nav_msgs_msg_dds__Odometry__desc, "rt/odom", reliable_qos(100)),
      imu_(participant(), sensor_msgs_msg_dds__Imu__desc, "rt/imu", reliable_qos(100)),
      tf_(participant(), tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", reliable_qos(100)),
      tf_static_(participant(), tf2_msgs_msg_dds__TFMessage__desc, "rt/tf_static", latched_qos(1)),
      initial_pose_(participant(), geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "rt/initialpose",
                    reliable_qos(10)),
      clock_(participant(), rosgraph_msgs_msg_dds__Clock__desc, "rt/clock", {false, false, 1, ""}),
      trigger_(participant(), std_msgs_msg_dds__Empty__desc, "rt/tsdf_mcl/reinitialize_global_localization",
               reliable_qos(1)),
      status_(participant(), diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics", reliable_qos(100)),
      pose_(participant(), geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "rt/amcl_pose", reliable_qos(100)),
      tf_in_(participant(), tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", reliable_qos(100)) {
  loop_ = std::make_unique<MessageLoop>(participant(), [](const std::string& what) { ADD_FAILURE() << what; });
  loop_->add(status_, [this](const Sample& s) {
    const auto& m = *static_cast<const diagnostic_msgs_msg_dds__DiagnosticArray_*>(s.get());
    for (std::uint32_t i = 0; i < m.status._length; ++i) {
      const diagnostic_msgs_msg_dds__DiagnosticStatus_& st = m.status._buffer[i];
      if (std::string(st.name) != "tsdf_mcl: localization") continue;
      node::DiagnosticOut d;
      d.stamp = stamp_of(m.header.stamp);
      d.level = static_cast<node::DiagnosticOut::Level>(st.level);
      d.name = st.name;
      d.message = st.message;
      d.hardware_id = st.hardware_id;
      for (std::uint32_t k = 0; k < st.values._length; ++k) {
        d.values.emplace_back(st.values._buffer[k].key, st.values._buffer[k].value);
      }
      heard_.status(d);
    }
  });
  loop_->add(pose_, [this](const Sample& s) {
    const auto& m = *static_cast<const geometry_msgs_msg_dds__PoseWithCovarianceStamped_*>(s.get());
    node::PoseOut p;
    p.stamp = stamp_of(m.header.stamp);
    p.frame_id = m.header.frame_id;
    p.pose = node::to_pose(raw_pose(m.pose.pose));
    std::copy(m.pose.covariance, m.pose.covariance + 36, p.covariance.begin());
    heard_.pose(p);
  });
  loop_->add(tf_in_, [this](const Sample& s) {
    for (const node::TransformMsg& t : transforms_of(*static_cast<const tf2_msgs_msg_dds__TFMessage_*>(s.get()))) {
      if (t.header.frame_id != "map" || t.child_frame_id != "odom") continue;
      node::TransformOut out;
      out.stamp = node::to_stamp(t.header.stamp);
      out.parent = t.header.frame_id;
      out.child = t.child_frame_id;
      out.pose = node::to_pose(t.transform);
      heard_.map_odom(out);
    }
  });
  loop_->start();
}

DdsLink::~DdsLink() { loop_.reset(); }

bool DdsLink::connected(std::chrono::seconds timeout) {
  std::vector<dds_entity_t> endpoints;
  for (const Writer* w : {&points_, &tf_, &tf_static_, &initial_pose_, &trigger_}) endpoints.push_back(w->handle());
  for (const Reader* r : {&status_, &pose_}) endpoints.push_back(r->handle());
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (const dds_entity_t e : endpoints) {
    // Waits on the match, a second at a time only to notice a node that ended (a bad start) without waiting it out.
    while (!wait_for_matched(participant(), e, 1, std::chrono::seconds(1))) {
      if (!node_.running() || std::chrono::steady_clock::now() > deadline) return false;
    }
  }
  return true;
}

void DdsLink::tf(const std::vector<node::TransformMsg>& transforms, bool is_static) {
  std::vector<geometry_msgs_msg_dds__TransformStamped_> items;
  for (const node::TransformMsg& t : transforms) {
    const geometry_msgs_msg_dds__Pose_ p = pose_of(t.transform);
    items.push_back({{time_of(t.header.stamp), text(t.header.frame_id)},
                     text(t.child_frame_id),
                     {{p.position.x, p.position.y, p.position.z}, p.orientation}});
  }
  tf2_msgs_msg_dds__TFMessage_ m{};
  m.transforms._length = m.transforms._maximum = static_cast<std::uint32_t>(items.size());
  m.transforms._buffer = items.data();
  (is_static ? tf_static_ : tf_).write(&m);
}

void DdsLink::cloud(const PointCloud& cloud, const node::RawStamp& stamp, const std::string& frame) {
  node::CloudOut out;
  out.frame_id = frame;
  out.cloud = encode_pointcloud2(cloud);
  CloudMessage m(out);
  m.msg.header.stamp = time_of(stamp);  // the raw stamp as given, whatever it is
  heard_.forget(node::to_stamp(stamp));
  points_.write(&m.msg);
}

void DdsLink::odometry(const node::OdometryMsg& o) {
  nav_msgs_msg_dds__Odometry_ m{};
  m.header = {time_of(o.header.stamp), text(o.header.frame_id)};
  m.child_frame_id = const_cast<char*>("base_link");
  m.pose.pose = pose_of(o.pose);
  odom_.write(&m);
}

void DdsLink::imu(const node::ImuMsg& i) {
  sensor_msgs_msg_dds__Imu_ m{};
  m.header = {time_of(i.header.stamp), text(i.header.frame_id)};
  m.orientation_covariance[0] = -1.0;
  m.linear_acceleration = {i.linear_acceleration.x(), i.linear_acceleration.y(), i.linear_acceleration.z()};
  imu_.write(&m);
}

void DdsLink::clock(const node::RawStamp& now) {
  const rosgraph_msgs_msg_dds__Clock_ m{time_of(now)};
  clock_.write(&m);
}

void DdsLink::initial_pose(const node::InitialPoseMsg& p) {
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ m{};
  m.header = {time_of(p.header.stamp), text(p.header.frame_id)};
  m.pose.pose = pose_of(p.pose);
  initial_pose_.write(&m);
}

void DdsLink::global_localization() {
  EXPECT_TRUE(call_service("/reinitialize_global_localization", std::chrono::seconds(60)));
}

void DdsLink::trigger_global_localization() {
  const std_msgs_msg_dds__Empty_ m{0};
  trigger_.write(&m);
}

bool DdsLink::call_service(const std::string& name, std::chrono::seconds timeout) {
  // An rmw_cyclonedds_cpp client: a request writer and a reply reader, matched with the service's before the call.
  const Qos qos = reliable_qos(10);
  const Writer requests(participant(), std_srvs_srv_dds__Empty_Request__desc, dds_request_topic(name), qos);
  const Reader replies(participant(), std_srvs_srv_dds__Empty_Response__desc, dds_reply_topic(name), qos);
  if (!wait_for_matched(participant(), requests.handle(), 1, timeout) ||
      !wait_for_matched(participant(), replies.handle(), 1, timeout)) {
    return false;
  }
  const std::uint64_t client = 0x7473646663ULL;  // the request writer's id, which the reply repeats
  const std::int64_t sequence = ++service_calls_;
  const std_srvs_srv_dds__Empty_Request_ request{client, sequence, 0};
  requests.write(&request);
  const dds_entity_t waitset = dds_create_waitset(participant());
  const dds_entity_t condition = dds_create_readcondition(replies.handle(), DDS_ANY_STATE);
  dds_waitset_attach(waitset, condition, 0);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  bool answered = false;
  while (!answered && std::chrono::steady_clock::now() < deadline) {
    dds_waitset_wait(
        waitset, nullptr, 0,
        std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now()).count());
    while (const Sample s = replies.take()) {
      const auto& reply = *static_cast<const std_srvs_srv_dds__Empty_Response_*>(s.get());
      answered = answered || (reply.client_guid == client && reply.sequence_number == sequence);
    }
  }
  dds_delete(condition);
  dds_delete(waitset);
  return answered;
}

std::optional<node::test::Heard> DdsLink::heard(const node::RawStamp& scan, std::chrono::seconds timeout) {
  return heard_.heard(node::to_stamp(scan), timeout);
}

std::optional<node::TransformOut> DdsLink::map_odom(const node::RawStamp& scan, std::chrono::seconds timeout) {
  return heard_.map_odom(node::to_stamp(scan), timeout);
}

}  // namespace tsdf_mcl::ros2_node::test
