#pragma once
// The dataset layout of docs/architecture.md: DIR/scans/NNNNNN.bin (float32 x y z intensity), times.txt,
// optional poses.txt (world_T_sensor) and odom.txt (odom_T_sensor), KITTI 3x4 row-major, optional imu.txt.
// The same Dataset also reads a ROS 1 bag or a rosbag2 recording (Dataset::open_bag, docs/bags.md).
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/io/imu.hpp"
#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl {

// --start S --stride K --count N (count 0 = all remaining).
struct ScanSelection {
  std::size_t start = 0;
  std::size_t stride = 1;
  std::size_t count = 0;

  std::vector<std::size_t> indices(std::size_t scan_count) const;
};

// Where a bag dataset finds what (docs/bags.md). Topic names match with or without their leading '/'.
struct BagOptions {
  std::string points_topic;         // sensor_msgs/PointCloud2: the scans, at their header stamps (required)
  std::string odom_frame = "odom";  // odometry from tf odom_frame -> base_frame, ...
  std::string base_frame = "base_link";
  std::string odom_topic;          // ... or from this nav_msgs/Odometry topic (header.frame_id -> child_frame_id)
  std::string ground_truth_topic;  // nav_msgs/Odometry, geometry_msgs/PoseStamped or PoseWithCovarianceStamped,
                                   // world_T_base: poses
  std::string imu_topic;           // sensor_msgs/Imu: imu()
  std::string tf_topic = "/tf";
  std::string tf_static_topic = "/tf_static";
};

class Dataset {
 public:
  // Reads times.txt, poses.txt and odom.txt (if present) and lists the scans; checks that the line
  // counts agree with the number of scans. Throws Error naming the file at fault.
  static Dataset open(const std::filesystem::path& dir);

  // A bag as a dataset, without ROS: a ROS 1 bag, or a rosbag2 recording (its folder, or one .db3 or .mcap file),
  // recognized by its content. The scans' header stamps, odometry (odom_T_sensor: tf or odom_topic, interpolated at
  // each stamp, composed with tf base_frame -> the clouds' frame), ground truth (world_T_sensor likewise) and IMU
  // samples (rotated into the clouds' frame) are read when the bag is opened; the clouds themselves only by
  // load_scan. Scans before the first or after the last odometry or ground truth sample are left out (summary()
  // says how many). Throws Error in one sentence: not a bag, a corrupt or truncated bag, a missing topic (naming
  // those of the type there are), a topic of the wrong type, frames that no tf connects, scans out of order; a ROS 1
  // bag where the library was built without rosbag_storage (ros1_bag_support() false).
  static Dataset open_bag(const std::filesystem::path& file, const BagOptions& options);
  static bool ros1_bag_support();

  std::size_t size() const { return times_.size(); }
  const std::filesystem::path& dir() const { return dir_; }
  double time(std::size_t i) const { return times_.at(i); }
  bool has_poses() const { return !poses_.empty(); }
  bool has_odometry() const { return !odometry_.empty(); }
  const Pose& pose(std::size_t i) const { return poses_.at(i); }         // world_T_sensor
  const Pose& odometry(std::size_t i) const { return odometry_.at(i); }  // odom_T_sensor
  const std::vector<Pose>& poses() const { return poses_; }
  // Replaces the ground truth (one pose per scan, world_T_sensor), e.g. with a trajectory's (pose_at).
  void set_poses(std::vector<Pose> poses);
  const std::vector<double>& times() const { return times_; }
  bool is_bag() const { return source_ != nullptr; }
  // What was read from where, in a line (bags; empty for folders).
  const std::string& summary() const { return summary_; }
  // "dataset DIR has no odom.txt" / "bag FILE has no odometry (...)", for commands that need it.
  std::string missing_odometry() const;
  std::string missing_poses() const;
  // IMU samples in the sensor frame: a folder's imu.txt (read now; none without the file), a bag's imu_topic.
  std::vector<ImuSample> imu() const;

  // Loads scan i (.bin, or .pcd / .ply of the same stem). Non-finite points are dropped and counted. One policy
  // for every command: a scan without points, or without a finite one, is an Error naming the file.
  PointCloud load_scan(std::size_t i, std::size_t* dropped_non_finite = nullptr) const;
  // The same policy checked before work starts, on file sizes alone (empty files; bags: nothing to check).
  void check_scans_not_empty(const std::vector<std::size_t>& scans) const;
  // The scan's file; for a bag "FILE:TOPIC[i]", for messages.
  std::filesystem::path scan_path(std::size_t i) const;

  // Where a bag's scans come from (src/io/rosbag/, src/io/rosbag2/).
  class ScanSource {
   public:
    virtual ~ScanSource() = default;
    virtual PointCloud load(std::size_t i, std::size_t* dropped_non_finite) const = 0;
    virtual std::string name(std::size_t i) const = 0;
  };

 private:
  std::filesystem::path dir_;  // a bag: its file
  std::shared_ptr<const ScanSource> source_;
  std::string summary_, missing_odometry_, missing_poses_;
  std::vector<ImuSample> imu_;
  std::vector<std::filesystem::path> scan_files_;
  std::vector<double> times_;
  std::vector<Pose> poses_;
  std::vector<Pose> odometry_;
};

// Writes a dataset in the same layout (the simulator's output).
class DatasetWriter {
 public:
  explicit DatasetWriter(const std::filesystem::path& dir);  // creates DIR/scans
  void add(double time, const PointCloud& scan, const std::optional<Pose>& pose, const std::optional<Pose>& odometry);
  void close();  // writes times.txt, poses.txt, odom.txt
  ~DatasetWriter();

 private:
  std::filesystem::path dir_;
  std::vector<double> times_;
  std::vector<Pose> poses_;
  std::vector<Pose> odometry_;
  bool closed_ = false;
};

// Scan file readers, usable on their own.
PointCloud read_kitti_bin(const std::filesystem::path& file);
void write_kitti_bin(const std::filesystem::path& file, const PointCloud& cloud);
std::vector<Pose> read_kitti_poses(const std::filesystem::path& file);
void write_kitti_poses(const std::filesystem::path& file, const std::vector<Pose>& poses);

// TUM trajectory: "t x y z qx qy qz qw" per line.
struct StampedPose {
  double time = 0.0;
  Pose pose = Pose::Identity();
};
std::vector<StampedPose> read_tum(const std::filesystem::path& file);
// The trajectory's pose at `time`, interpolated between the poses around it (linear, slerp); nullopt outside its
// first..last time (1 us slack). The trajectory's times must not decrease.
std::optional<Pose> pose_at(const std::vector<StampedPose>& trajectory, double time);
void write_tum(const std::filesystem::path& file, const std::vector<StampedPose>& trajectory);

}  // namespace tsdf_mcl
