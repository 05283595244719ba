// The ROS 1 bag sink of BagWriter: rosbag_storage and the ROS message classes of Debian's ROS 1 packages. The
// writer is the one place where roscpp's serialization meets only our own data, and the message classes give every
// connection record its exact type, MD5 sum and full definition, which other tools (rosbag info, rqt_bag, Python's
// rosbag) need.
#include <boost/make_shared.hpp>
#include <filesystem>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include "../bag/bag_formats.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/ros_message_fields.hpp"

namespace tsdf_mcl::bag_io {
namespace fs = std::filesystem;

namespace {

ros::Time ros_time(double t) {
  // ros::Time holds unsigned seconds; a bag record needs a time after 0.
  if (!(t > 0.0) || t >= 4294967295.0) {
    throw Error("a bag message needs a time in 0..4294967295 s (exclusive), got " + std::to_string(t));
  }
  return ros::Time(t);
}

std_msgs::Header header_msg(const msg::Header& h) {
  std_msgs::Header out;
  out.seq = h.seq;
  out.stamp = ros::Time(static_cast<std::uint32_t>(h.sec), h.nsec);
  out.frame_id = h.frame_id;
  return out;
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

class Ros1Sink : public BagSink {
 public:
  explicit Ros1Sink(const fs::path& file) : file_(file), partial_(file.string() + ".partial") {
    std::error_code ec;
    if (fs::is_directory(file, ec)) throw Error("bag " + file.string() + " is a directory");
    try {
      bag_.open(partial_.string(), rosbag::bagmode::Write);
    } catch (const std::exception& e) {
      throw Error("cannot create bag " + partial_.string() + ": " + e.what());
    }
  }

  ~Ros1Sink() override {
    if (finished_) return;
    try {
      bag_.close();
    } catch (...) {
      // Destructors must not throw; the partial file goes anyway.
    }
    std::error_code ignored;
    fs::remove(partial_, ignored);
  }

  void write_tf(const std::string& topic, double time, const std::vector<msg::TransformStamped>& transforms,
                bool is_static) override {
    tf2_msgs::TFMessage tf;
    for (const msg::TransformStamped& t : transforms) {
      geometry_msgs::TransformStamped out;
      out.header = header_msg(t.header);
      out.child_frame_id = t.child_frame_id;
      out.transform = transform_msg(t.transform);
      tf.transforms.push_back(out);
    }
    write(topic, time, tf, is_static);
  }

  void write_points(const std::string& topic, double time, const msg::Header& header,
                    const EncodedPointCloud2& cloud) override {
    sensor_msgs::PointCloud2 m;
    m.header = header_msg(header);
    fill_pointcloud2_message(cloud, m);
    write(topic, time, m);
  }

  void write_odometry(const std::string& topic, double time, const msg::PoseMessage& odometry) override {
    nav_msgs::Odometry m;
    m.header = header_msg(odometry.header);
    m.child_frame_id = odometry.child_frame_id;
    m.pose.pose = pose_msg(odometry.pose);
    write(topic, time, m);
  }

  void write_imu(const std::string& topic, double time, const msg::Imu& imu) override {
    sensor_msgs::Imu m;
    m.header = header_msg(imu.header);
    m.orientation_covariance[0] = -1.0;  // no orientation (REP 145)
    m.angular_velocity.x = imu.angular_velocity.x();
    m.angular_velocity.y = imu.angular_velocity.y();
    m.angular_velocity.z = imu.angular_velocity.z();
    m.linear_acceleration.x = imu.linear_acceleration.x();
    m.linear_acceleration.y = imu.linear_acceleration.y();
    m.linear_acceleration.z = imu.linear_acceleration.z();
    write(topic, time, m);
  }

  void finish() override {
    try {
      bag_.close();
    } catch (const std::exception& e) {
      throw Error("cannot write " + partial_.string() + ": " + e.what());
    }
    finished_ = true;
    std::error_code ec;
    fs::rename(partial_, file_, ec);
    if (ec) throw Error("cannot rename " + partial_.string() + " to " + file_.string() + ": " + ec.message());
  }

 private:
  // `latched`: the connection header says latching=1, as `rosbag record` keeps it from a latched publisher, so
  // `rosbag play` latches the topic again and a subscriber that connects late still receives it.
  template <typename Message>
  void write(const std::string& topic, double time, const Message& message, bool latched = false) {
    const ros::Time stamp = ros_time(time);
    try {
      if (!latched) {
        bag_.write(topic, stamp, message);
        return;
      }
      auto header = boost::make_shared<ros::M_string>();
      (*header)["type"] = ros::message_traits::datatype(message);
      (*header)["md5sum"] = ros::message_traits::md5sum(message);
      (*header)["message_definition"] = ros::message_traits::definition(message);
      (*header)["callerid"] = "/tsdf_mcl_simulate";
      (*header)["latching"] = "1";
      bag_.write(topic, stamp, message, header);
    } catch (const std::exception& e) {
      throw Error("cannot write " + partial_.string() + ": " + e.what());
    }
  }

  fs::path file_, partial_;
  rosbag::Bag bag_;
  bool finished_ = false;
};

}  // namespace

std::unique_ptr<BagSink> make_ros1_sink(const fs::path& file, const BagWriterOptions&) {
  return std::make_unique<Ros1Sink>(file);
}

}  // namespace tsdf_mcl::bag_io
