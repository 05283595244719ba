#pragma once
// Writing a run as a ROS 1 bag (simulate --bag; docs/bags.md), through rosbag_storage, without a ROS master:
//
//   points_topic        sensor_msgs/PointCloud2  frame cloud_frame: x y z intensity FLOAT32 (+ ring UINT16 where
//                                                the scans have rings), header stamp = the scan's time
//   /tf                 tf2_msgs/TFMessage       odom_frame -> base_frame (odom_T_sensor * sensor_T_base) per scan
//   /tf_static          tf2_msgs/TFMessage       base_frame -> cloud_frame (base_T_sensor), once, latched
//                                                (connection header latching=1, as `rosbag record` writes it)
//   odom_topic          nav_msgs/Odometry        odom_frame -> base_frame, the same as /tf ("" = not written)
//   ground_truth_topic  nav_msgs/Odometry        world_frame -> base_frame (world_T_sensor * sensor_T_base)
//   imu_topic           sensor_msgs/Imu          frame cloud_frame (the IMU sits in the LiDAR), add_imu's samples
//
// Dataset::open_bag(file, {points_topic, odom_frame, base_frame, ..., ground_truth_topic, imu_topic}) reads it back
// as the dataset it was written from. Built without rosbag_storage, the constructor throws "built without ROS bag
// support".
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl {

struct BagWriterOptions {
  std::string points_topic = "/points";
  std::string cloud_frame = "lidar";
  std::string base_frame = "base_link";
  std::string odom_frame = "odom";
  std::string world_frame = "map";
  std::string odom_topic = "/odom";
  std::string ground_truth_topic = "/ground_truth";
  std::string imu_topic = "/imu";
};

class BagWriter {
 public:
  // Writes FILE.partial beside FILE, renamed to FILE by close(): a run that fails leaves no half-written bag.
  explicit BagWriter(const std::filesystem::path& file, BagWriterOptions options = {});
  ~BagWriter();  // without close(), removes FILE.partial
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  // The sensor's mounting on the base, base_T_sensor (identity, the default, where the odometry is the sensor's
  // own); before the first scan, which writes it to /tf_static.
  void set_base_T_sensor(const Pose& base_T_sensor);
  // One scan at `time` (s, > 0; strictly increasing): the cloud in the sensor frame, rings (one per point) or
  // nullptr, the true pose and the odometry of the sensor where known.
  void add_scan(double time, const PointCloud& cloud, const std::vector<std::uint16_t>* rings,
                const std::optional<Pose>& world_T_sensor, const std::optional<Pose>& odom_T_sensor);
  // One IMU sample in the sensor frame: specific force (m/s^2) and angular rate (rad/s).
  void add_imu(double time, const Eigen::Vector3d& acceleration, const Eigen::Vector3d& angular_velocity);
  std::size_t scans() const;
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tsdf_mcl
