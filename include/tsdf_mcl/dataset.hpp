#pragma once
// The dataset layout of DESIGN.md: DIR/scans/NNNNNN.bin (float32 x y z intensity), times.txt,
// optional poses.txt (world_T_sensor) and odom.txt (odom_T_sensor), KITTI 3x4 row-major.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/point_cloud.hpp"
#include "tsdf_mcl/pose.hpp"

namespace tsdf_mcl {

// --start S --stride K --count N (count 0 = all remaining).
struct ScanSelection {
  std::size_t start = 0;
  std::size_t stride = 1;
  std::size_t count = 0;

  std::vector<std::size_t> indices(std::size_t scan_count) const;
};

class Dataset {
 public:
  // Reads times.txt, poses.txt and odom.txt (if present) and lists the scans; checks that the line
  // counts agree with the number of scans. Throws Error naming the file at fault.
  static Dataset open(const std::filesystem::path& dir);

  std::size_t size() const { return times_.size(); }
  const std::filesystem::path& dir() const { return dir_; }
  double time(std::size_t i) const { return times_.at(i); }
  bool has_poses() const { return !poses_.empty(); }
  bool has_odometry() const { return !odometry_.empty(); }
  const Pose& pose(std::size_t i) const { return poses_.at(i); }        // world_T_sensor
  const Pose& odometry(std::size_t i) const { return odometry_.at(i); }  // odom_T_sensor
  const std::vector<Pose>& poses() const { return poses_; }
  const std::vector<double>& times() const { return times_; }

  // Loads scan i (.bin, or .pcd / .ply of the same stem). Non-finite points are dropped and counted.
  PointCloud load_scan(std::size_t i, std::size_t* dropped_non_finite = nullptr) const;
  std::filesystem::path scan_path(std::size_t i) const;

 private:
  std::filesystem::path dir_;
  std::vector<std::filesystem::path> scan_files_;
  std::vector<double> times_;
  std::vector<Pose> poses_;
  std::vector<Pose> odometry_;
};

// Writes a dataset in the same layout (the simulator's output).
class DatasetWriter {
 public:
  explicit DatasetWriter(const std::filesystem::path& dir);  // creates DIR/scans
  void add(double time, const PointCloud& scan, const std::optional<Pose>& pose,
           const std::optional<Pose>& odometry);
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
void write_tum(const std::filesystem::path& file, const std::vector<StampedPose>& trajectory);

}  // namespace tsdf_mcl
