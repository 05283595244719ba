// The dataset's text files: stamps and translations within their ranges on reading, and nothing non-finite written.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "map_test_helpers.hpp"
#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl {
namespace {

using test::error_of;

using test::TempDir;
using test::write_bytes;

const char* kIdentity = "1 0 0 0 0 1 0 0 0 0 1 0\n";

// A dataset of two scans with the given times.txt and odom.txt.
void write_dataset(const TempDir& dir, const std::string& times, const std::string& odom) {
  std::filesystem::create_directories(dir / "scans");
  PointCloud cloud;
  cloud.points = {Eigen::Vector3f(1, 0, 0)};
  write_kitti_bin(dir / "scans" / "000000.bin", cloud);
  write_kitti_bin(dir / "scans" / "000001.bin", cloud);
  write_bytes(dir / "times.txt", times);
  write_bytes(dir / "odom.txt", odom);
}

TEST(DatasetFiles, StampsBeyondRosTimeAreRefused) {
  const std::string odom = std::string(kIdentity) + kIdentity;
  for (const char* times : {"0\n1e300\n", "0\n4294967297\n", "-4294967297\n0\n"}) {
    TempDir dir;
    write_dataset(dir, times, odom);
    const std::string what = error_of([&] { Dataset::open(dir.path()); });
    EXPECT_NE(what.find("times.txt:"), std::string::npos) << times << what;
    EXPECT_NE(what.find("beyond +-2^32 s"), std::string::npos) << what;
  }
  TempDir dir;
  write_dataset(dir, "1700000000.5\n4294967295\n", odom);  // unix time, and the last second ROS 1 time has
  EXPECT_EQ(Dataset::open(dir.path()).time(1), 4294967295.0);
}

TEST(DatasetFiles, TranslationsBeyondAnyMapAreRefused) {
  for (const char* far :
       {"1 0 0 1e30 0 1 0 0 0 0 1 0\n", "1 0 0 0 0 1 0 -3e8 0 0 1 0\n", "1 0 0 0 0 1 0 0 0 0 1 1e300\n"}) {
    TempDir dir;
    write_dataset(dir, "0\n1\n", std::string(kIdentity) + far);
    const std::string what = error_of([&] { Dataset::open(dir.path()); });
    EXPECT_NE(what.find("odom.txt:2:"), std::string::npos) << far << what;
    EXPECT_NE(what.find("beyond +-2^28 m"), std::string::npos) << what;
  }
  TempDir dir;
  write_dataset(dir, "0\n1\n", std::string(kIdentity) + "1 0 0 2e8 0 1 0 0 0 0 1 0\n");
  EXPECT_EQ(Dataset::open(dir.path()).odometry(1).translation().x(), 2e8);
}

TEST(DatasetFiles, NothingNonFiniteIsWritten) {
  TempDir dir;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  StampedPose bad;
  bad.pose.translation().x() = nan;
  EXPECT_NE(error_of([&] { write_tum(dir / "t.tum", {StampedPose{}, bad}); }).find("non-finite"), std::string::npos);
  EXPECT_NE(error_of([&] {
              write_tum(dir / "t.tum", {StampedPose{nan, Pose::Identity()}});
            }).find("line 1"),
            std::string::npos);
  Pose inf = Pose::Identity();
  inf.translation().z() = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of([&] { write_kitti_poses(dir / "p.txt", {inf}); }).find("non-finite"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "t.tum"));
  EXPECT_FALSE(std::filesystem::exists(dir / "p.txt"));
  DatasetWriter writer(dir / "sim");
  PointCloud cloud;
  cloud.points = {Eigen::Vector3f(1, 0, 0)};
  writer.add(nan, cloud, Pose::Identity(), inf);
  EXPECT_NE(error_of([&] { writer.close(); }).find("times.txt line 1"), std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl
