// BagWriter: what a run's bag holds (bag_writer.hpp), the same in every format; the sink of the format
// (bag_formats.hpp) encodes and stores it.
#include "tsdf_mcl/io/bag_writer.hpp"

#include "bag_formats.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

struct BagWriter::Impl {
  fs::path file;
  BagWriterOptions options;
  std::unique_ptr<bag_io::BagSink> sink;
  Pose sensor_T_base = Pose::Identity(), base_T_sensor = Pose::Identity();
  std::size_t scans = 0;
  double last_time = 0.0;
  bool closed = false;

  void check_open() const {
    if (closed) throw Error("bag " + file.string() + " is closed");
  }
  // The header of a message at `time` in `frame`; ROS 1's seq counts the scans.
  msg::Header header(double time, const std::string& frame) const {
    if (!(time > 0.0)) throw Error("a bag message needs a time after 0 s, got " + std::to_string(time));
    msg::Header h = msg::stamp_of(time);
    h.seq = static_cast<std::uint32_t>(scans);
    h.frame_id = frame;
    return h;
  }
};

BagWriter::BagWriter(const fs::path& file, BagWriterOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.file = file;
  w.options = std::move(options);
  w.sink =
      file.extension() == ".bag" ? bag_io::make_ros1_sink(file, w.options) : bag_io::make_rosbag2_sink(file, w.options);
}

BagWriter::~BagWriter() = default;

std::size_t BagWriter::scans() const { return impl_->scans; }

void BagWriter::set_base_T_sensor(const Pose& base_T_sensor) {
  if (impl_->scans > 0) throw Error("the bag's extrinsic is written with its first scan: set it before");
  impl_->base_T_sensor = base_T_sensor;
  impl_->sensor_T_base = base_T_sensor.inverse();
}

void BagWriter::add_scan(double time, const PointCloud& cloud, const std::vector<std::uint16_t>* rings,
                         const std::optional<Pose>& world_T_sensor, const std::optional<Pose>& odom_T_sensor) {
  Impl& w = *impl_;
  w.check_open();
  if (w.scans > 0 && !(time > w.last_time)) {
    throw Error("bag scan times must increase (" + std::to_string(time) + " after " + std::to_string(w.last_time) +
                ")");
  }
  const BagWriterOptions& o = w.options;
  if (w.scans == 0) {
    // The extrinsic, once, at the first scan's time (a latched /tf_static holds it from then on).
    msg::TransformStamped t{w.header(time, o.base_frame), o.cloud_frame, w.base_T_sensor};
    t.header.seq = 0;
    w.sink->write_tf("/tf_static", time, {t}, true);
  }
  w.sink->write_points(o.points_topic, time, w.header(time, o.cloud_frame), encode_pointcloud2(cloud, rings));
  if (odom_T_sensor) {
    const msg::TransformStamped t{w.header(time, o.odom_frame), o.base_frame, *odom_T_sensor * w.sensor_T_base};
    w.sink->write_tf("/tf", time, {t}, false);
    if (!o.odom_topic.empty()) w.sink->write_odometry(o.odom_topic, time, {t.header, o.base_frame, t.transform});
  }
  if (world_T_sensor && !o.ground_truth_topic.empty()) {
    w.sink->write_odometry(o.ground_truth_topic, time,
                           {w.header(time, o.world_frame), o.base_frame, *world_T_sensor * w.sensor_T_base});
  }
  w.last_time = time;
  ++w.scans;
}

void BagWriter::add_imu(double time, const Eigen::Vector3d& acceleration, const Eigen::Vector3d& angular_velocity) {
  Impl& w = *impl_;
  w.check_open();
  if (w.options.imu_topic.empty()) return;
  msg::Header h = w.header(time, w.options.cloud_frame);
  h.seq = 0;
  w.sink->write_imu(w.options.imu_topic, time, {h, angular_velocity, acceleration});
}

void BagWriter::close() {
  Impl& w = *impl_;
  if (w.closed) return;
  w.sink->finish();
  w.closed = true;
}

}  // namespace tsdf_mcl
