#pragma once
// Writing a run as a bag (simulate --bag; docs/bags.md), without a ROS master or a ROS 2 installation. The name
// picks the format: FILE.bag a ROS 1 bag (through rosbag_storage), FILE.mcap or FILE.db3 one rosbag2 storage file
// (MCAP or SQLite3), any other name a rosbag2 folder as `ros2 bag record -o NAME` writes it (metadata.yaml beside
// NAME_0.mcap, or .db3 with storage "sqlite3"). The topics are the same in every format (ROS 2 type names are
// "sensor_msgs/msg/PointCloud2" and so on):
//
//   points_topic        sensor_msgs/PointCloud2  frame cloud_frame: x y z intensity FLOAT32 (+ ring UINT16 where
//                                                the scans have rings), header stamp = the scan's time
//   /tf                 tf2_msgs/TFMessage       odom_frame -> base_frame (odom_T_sensor * sensor_T_base) per scan
//   /tf_static          tf2_msgs/TFMessage       base_frame -> cloud_frame (base_T_sensor), once, latched
//                                                (ROS 1: connection header latching=1, as `rosbag record` writes it;
//                                                ROS 2: offered durability transient_local)
//   odom_topic          nav_msgs/Odometry        odom_frame -> base_frame, the same as /tf ("" = not written)
//   ground_truth_topic  nav_msgs/Odometry        world_frame -> base_frame (world_T_sensor * sensor_T_base)
//   imu_topic           sensor_msgs/Imu          frame cloud_frame (the IMU sits in the LiDAR), add_imu's samples
//
// Dataset::open_bag(file, {points_topic, odom_frame, base_frame, ..., ground_truth_topic, imu_topic}) reads it back
// as the dataset it was written from. A ROS 1 bag where the library was built without rosbag_storage: the
// constructor throws "built without ROS 1 bag support".
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
  // rosbag2 only.
  std::string storage = "mcap";  // a folder's storage files: "mcap" or "sqlite3"
  std::string compression;       // MCAP chunks: "" (none, as rosbag2 writes by default), "zstd" or "lz4"
  bool mcap_summary = true;      // false: an MCAP file ends at its data end, with no summary and no index
  std::uint64_t mcap_chunk_bytes = 768 * 1024;  // an MCAP chunk is closed once its records hold this much
  std::uint64_t split_bytes = 0;                // a folder: the next storage file once one holds more (0: one file), as
                                                // `ros2 bag record --max-bag-size`
};

class BagWriter {
 public:
  // Writes FILE.partial beside FILE (a folder: NAME.partial/), renamed by close(): a run that fails leaves no
  // half-written bag.
  explicit BagWriter(const std::filesystem::path& file, BagWriterOptions options = {});
  ~BagWriter();  // without close(), removes what it wrote
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
