// Dataset::open_bag: the bag's format from its first bytes (docs/bags.md), then that format's store and the one
// dataset code path (contents_reader.hpp).
#include <fstream>

#include "bag_formats.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/core/input_file.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

namespace bag_io {

FileSignature file_signature(const fs::path& file) {
  input_file_size(file, "bag", limits::kMaxBagFileBytes);
  std::ifstream in(file, std::ios::binary);
  char bytes[32] = {};
  in.read(bytes, sizeof(bytes));
  const std::string head(bytes, static_cast<std::size_t>(in.gcount()));
  const auto starts = [&](const std::string& magic) { return head.compare(0, magic.size(), magic) == 0; };
  if (starts("#ROSBAG V")) return FileSignature::ros1_bag;
  if (starts(std::string("SQLite format 3\0", 16))) return FileSignature::sqlite3;
  if (starts("\x89MCAP0\r\n")) return FileSignature::mcap;
  if (starts("\x28\xB5\x2F\xFD")) return FileSignature::zstd;
  if (starts("rosbag2_bagfile_information:")) return FileSignature::rosbag2_metadata;
  return FileSignature::other;
}

}  // namespace bag_io

bool Dataset::ros1_bag_support() { return bag_io::ros1_bag_support(); }

Dataset Dataset::open_bag(const fs::path& file, const BagOptions& options) {
  if (options.points_topic.empty()) {
    throw Error("no points topic given (--points: the sensor_msgs/PointCloud2 topic of the scans)");
  }
  std::error_code ec;
  const bool ros1 = !fs::is_directory(file, ec) && bag_io::file_signature(file) == bag_io::FileSignature::ros1_bag;
  bag_io::OpenedBag bag = ros1 ? bag_io::open_ros1_bag(file, options) : bag_io::open_rosbag2(file, options);
  Dataset ds;
  ds.dir_ = file;
  ds.source_ = std::move(bag.scans);
  ds.times_ = std::move(bag.contents.times);
  ds.odometry_ = std::move(bag.contents.odometry);
  ds.poses_ = std::move(bag.contents.poses);
  ds.imu_ = std::move(bag.contents.imu);
  ds.summary_ = std::move(bag.contents.summary);
  ds.missing_odometry_ = std::move(bag.contents.missing_odometry);
  ds.missing_poses_ = std::move(bag.contents.missing_poses);
  return ds;
}

}  // namespace tsdf_mcl
