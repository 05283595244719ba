#pragma once
// What Dataset::open_bag learns in its child process (bag_dataset.cpp), and the bytes it crosses the pipe as
// (private to src/io/rosbag/). decode checks every count against the bytes left: a child that died halfway answers
// an Error, not a crash.
#include <cstdint>
#include <string>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/imu.hpp"

namespace tsdf_mcl::bag_io {

// Everything open_bag learns from the bag but the points: what the child process hands to the parent.
struct BagContents {
  std::string points_topic;                  // as the bag spells it
  std::vector<std::uint64_t> scan_ordinals;  // the kept scans, by position among the points topic's messages
  std::vector<double> times;
  std::vector<Pose> odometry, poses;
  std::vector<ImuSample> imu;
  std::string summary, missing_odometry, missing_poses;
};

std::string encode(const BagContents& c);
BagContents decode(const std::string& bytes);

}  // namespace tsdf_mcl::bag_io
