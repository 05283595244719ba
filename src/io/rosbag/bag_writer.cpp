// Writes bags with rosbag_storage and the ROS message classes of Debian's ROS 1 packages: the writer is the one
// place where roscpp's serialization meets only our own data, and the message classes give every connection record
// its exact type, MD5 sum and full definition, which other tools (rosbag info, rqt_bag, Python's rosbag) need.
#include <unistd.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <filesystem>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros_message_fields.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

namespace {

ros::Time ros_time(double t) {
  // ros::Time holds unsigned seconds; a bag record needs a time after 0.
  if (!(t > 0.0) || t >= 4294967295.0) {
    throw Error("a bag message needs a time in 0..4294967295 s (exclusive), got " + std::to_string(t));
  }
  return ros::Time(t);
}

geometry_msgs::Transform transform_msg(const Pose& p) {
  geometry_msgs::Transform t;
  fill_pose_fields(p, t.translation, t.rotation);
  return t;
}

geometry_msgs::Pose pose_msg(const Pose& p) {
  geometry_msgs::Pose out;
  fill_pose_fields(p, out.position, out.orientation);
  return out;
}

}  // namespace

struct BagWriter::Impl {
  fs::path file, partial;
  Pose sensor_T_base = Pose::Identity(), base_T_sensor = Pose::Identity();
  BagWriterOptions options;
  rosbag::Bag bag;
  std::size_t scans = 0;
  double last_time = 0.0;
  bool closed = false;

  // `latched`: the connection header says latching=1, as `rosbag record` keeps it from a latched publisher, so
  // `rosbag play` latches the topic again and a subscriber that connects late still receives it.
  template <typename Message>
  void write(const std::string& topic, const ros::Time& time, const Message& message, bool latched = false) {
    try {
      if (!latched) {
        bag.write(topic, time, message);
        return;
      }
      auto header = boost::make_shared<ros::M_string>();
      (*header)["type"] = ros::message_traits::datatype(message);
      (*header)["md5sum"] = ros::message_traits::md5sum(message);
      (*header)["message_definition"] = ros::message_traits::definition(message);
      (*header)["callerid"] = "/tsdf_mcl_simulate";
      (*header)["latching"] = "1";
      bag.write(topic, time, message, header);
    } catch (const std::exception& e) {
      throw Error("cannot write " + partial.string() + ": " + e.what());
    }
  }
};

BagWriter::BagWriter(const fs::path& file, BagWriterOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.file = file;
  w.partial = file.string() + ".partial";
  w.options = std::move(options);
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw Error("bag " + file.string() + " is a directory");
  try {
    w.bag.open(w.partial.string(), rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw Error("cannot create bag " + w.partial.string() + ": " + e.what());
  }
}

BagWriter::~BagWriter() {
  if (!impl_ || impl_->closed) return;
  try {
    impl_->bag.close();
  } catch (...) {
    // Destructors must not throw; the partial file goes anyway.
  }
  std::error_code ignored;
  fs::remove(impl_->partial, ignored);
}

std::size_t BagWriter::scans() const { return impl_->scans; }

void BagWriter::set_base_T_sensor(const Pose& base_T_sensor) {
  if (impl_->scans > 0) throw Error("the bag's extrinsic is written with its first scan: set it before");
  impl_->base_T_sensor = base_T_sensor;
  impl_->sensor_T_base = base_T_sensor.inverse();
}

void BagWriter::add_scan(double time, const PointCloud& cloud, const std::vector<std::uint16_t>* rings,
                         const std::optional<Pose>& world_T_sensor, const std::optional<Pose>& odom_T_sensor) {
  Impl& w = *impl_;
  if (w.closed) throw Error("bag " + w.file.string() + " is closed");
  if (w.scans > 0 && !(time > w.last_time)) {
    throw Error("bag scan times must increase (" + std::to_string(time) + " after " + std::to_string(w.last_time) +
                ")");
  }
  const ros::Time stamp = ros_time(time);
  const BagWriterOptions& o = w.options;
  if (w.scans == 0) {
    // The extrinsic, once, at the first scan's time (a latched /tf_static holds it from then on).
    tf2_msgs::TFMessage statics;
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = o.base_frame;
    t.child_frame_id = o.cloud_frame;
    t.transform = transform_msg(w.base_T_sensor);
    statics.transforms.push_back(t);
    w.write("/tf_static", stamp, statics, true);
  }

  sensor_msgs::PointCloud2 msg;
  msg.header.seq = static_cast<std::uint32_t>(w.scans);
  msg.header.stamp = stamp;
  msg.header.frame_id = o.cloud_frame;
  fill_pointcloud2_message(encode_pointcloud2(cloud, rings), msg);
  w.write(o.points_topic, stamp, msg);

  if (odom_T_sensor) {
    const Pose odom_T_base = *odom_T_sensor * w.sensor_T_base;
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped t;
    t.header.seq = static_cast<std::uint32_t>(w.scans);
    t.header.stamp = stamp;
    t.header.frame_id = o.odom_frame;
    t.child_frame_id = o.base_frame;
    t.transform = transform_msg(odom_T_base);
    tf.transforms.push_back(t);
    w.write("/tf", stamp, tf);
    if (!o.odom_topic.empty()) {
      nav_msgs::Odometry odom;
      odom.header = t.header;
      odom.child_frame_id = o.base_frame;
      odom.pose.pose = pose_msg(odom_T_base);
      w.write(o.odom_topic, stamp, odom);
    }
  }
  if (world_T_sensor && !o.ground_truth_topic.empty()) {
    nav_msgs::Odometry truth;
    truth.header.seq = static_cast<std::uint32_t>(w.scans);
    truth.header.stamp = stamp;
    truth.header.frame_id = o.world_frame;
    truth.child_frame_id = o.base_frame;
    truth.pose.pose = pose_msg(*world_T_sensor * w.sensor_T_base);
    w.write(o.ground_truth_topic, stamp, truth);
  }
  w.last_time = time;
  ++w.scans;
}

void BagWriter::add_imu(double time, const Eigen::Vector3d& acceleration, const Eigen::Vector3d& angular_velocity) {
  Impl& w = *impl_;
  if (w.closed) throw Error("bag " + w.file.string() + " is closed");
  if (w.options.imu_topic.empty()) return;
  sensor_msgs::Imu imu;
  imu.header.stamp = ros_time(time);
  imu.header.frame_id = w.options.cloud_frame;
  imu.orientation_covariance[0] = -1.0;  // no orientation (REP 145)
  imu.angular_velocity.x = angular_velocity.x();
  imu.angular_velocity.y = angular_velocity.y();
  imu.angular_velocity.z = angular_velocity.z();
  imu.linear_acceleration.x = acceleration.x();
  imu.linear_acceleration.y = acceleration.y();
  imu.linear_acceleration.z = acceleration.z();
  w.write(w.options.imu_topic, imu.header.stamp, imu);
}

void BagWriter::close() {
  Impl& w = *impl_;
  if (w.closed) return;
  try {
    w.bag.close();
  } catch (const std::exception& e) {
    throw Error("cannot write " + w.partial.string() + ": " + e.what());
  }
  w.closed = true;
  std::error_code ec;
  fs::rename(w.partial, w.file, ec);
  if (ec) throw Error("cannot rename " + w.partial.string() + " to " + w.file.string() + ": " + ec.message());
}

}  // namespace tsdf_mcl
