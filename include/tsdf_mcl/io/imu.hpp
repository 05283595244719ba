#pragma once
// Gravity from an IMU, for platforms that have one: DIR/imu.txt beside a dataset's scans.
//
// Format: one sample per line, "t ax ay az" optionally followed by "wx wy wz"; t in the clock of times.txt
// (s), the accelerometer's specific force in the LiDAR's sensor frame (m/s^2: the IMU-to-LiDAR rotation
// already applied), the angular rate (rad/s) is read and ignored. '#' starts a comment. At rest the
// accelerometer measures +9.81 m/s^2 straight up: averaged over a short window, it gives the up direction
// that the global search otherwise estimates from the scan (global_proposal.hpp).
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <vector>

namespace tsdf_mcl {

struct ImuSample {
  double time = 0.0;
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  // m/s^2, sensor frame
};

// Throws Error naming the file and line for unreadable numbers, fewer than four columns or times that go
// backwards.
std::vector<ImuSample> read_imu(const std::filesystem::path& file);

// The up direction in the sensor frame at `time`: the mean specific force of the samples within `window` s of
// it, normalized. nullopt without samples there or where the mean is not within 30 % of 9.81 m/s^2 (the
// platform was accelerating: the mean is not gravity).
std::optional<Eigen::Vector3f> imu_up_at(const std::vector<ImuSample>& samples, double time, double window = 0.1);

}  // namespace tsdf_mcl
