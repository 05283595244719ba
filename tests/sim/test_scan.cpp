#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>

#include "sim_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::PointCloud;
using tsdf_mcl::Pose;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::LidarModel;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::ScanNoise;
using tsdf_mcl::sim::simulate_scan;

namespace {

// A sensor in the office corridor, 0.5 m above the floor, looking along the corridor.
const Pose kCorridor = tsdf_mcl::pose_from_xyz_rpy(12.0, 10.3, 0.5, 0.0, 0.0, 0.3);

const TriangleMesh& office() {
  static const TriangleMesh mesh = tsdf_mcl::sim::office_scene(1);
  return mesh;
}

ScanNoise noise(double sigma, double dropout = 0.0) {
  ScanNoise n;
  n.range_sigma = sigma;
  n.dropout = dropout;
  return n;
}

}  // namespace

TEST(SimScan, ExactPointsLieOnTheMesh) {
  const RayCaster scene(office());
  const LidarModel lidar = LidarModel::vlp16(20.0);
  const PointCloud cloud = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.0), 1);
  // The office is closed: every ray returns.
  ASSERT_EQ(cloud.size(), lidar.rays());
  double worst = 0.0;
  for (std::size_t k = 0; k < cloud.size(); k += 29) {
    const Eigen::Vector3d world = kCorridor * cloud.points[k].cast<double>();
    worst = std::max(worst, tsdf_mcl::test::distance_to_mesh(office(), world));
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(SimScan, RangeNoiseHasTheRequestedSigma) {
  const RayCaster scene(office());
  const LidarModel lidar = LidarModel::os0_64();
  const PointCloud exact = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.0), 3);
  const PointCloud noisy = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.02), 3);
  // Nothing is close to the range limits here, so the two scans hold the same rays in the same order.
  ASSERT_EQ(exact.size(), lidar.rays());
  ASSERT_EQ(noisy.size(), exact.size());
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t k = 0; k < exact.size(); ++k) {
    const Eigen::Vector3d a = exact.points[k].cast<double>(), b = noisy.points[k].cast<double>();
    ASSERT_LT(a.normalized().dot(b.normalized()), 1.0 + 1e-6);
    ASSERT_GT(a.normalized().dot(b.normalized()), 1.0 - 1e-6);  // noise only along the beam
    const double r = b.norm() - a.norm();
    sum += r;
    sum_sq += r * r;
  }
  const double n = static_cast<double>(exact.size());
  const double mean = sum / n;
  const double sigma = std::sqrt(sum_sq / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.001);
  EXPECT_NEAR(sigma, 0.02, 0.0005);
}

TEST(SimScan, DropoutLosesTheRequestedShare) {
  const RayCaster scene(office());
  const LidarModel lidar = LidarModel::os0_64();
  const PointCloud cloud = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.01, 0.3), 5);
  EXPECT_NEAR(static_cast<double>(cloud.size()) / static_cast<double>(lidar.rays()), 0.7, 0.01);
}

TEST(SimScan, RaysBeyondRangeOrIntoTheSkyGiveNoPoint) {
  // A 20 x 20 m floor only: half of the beams look at the sky, the flat ones reach far.
  TriangleMesh floor;
  floor.vertices = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};
  const RayCaster scene(floor);
  LidarModel lidar = LidarModel::vlp16(10.0);
  lidar.min_range = 1.0;
  lidar.max_range = 4.0;
  const Pose pose = tsdf_mcl::pose_from_xyz_rpy(0, 0, 0.5, 0, 0, 0);
  const PointCloud cloud = simulate_scan(scene, lidar, pose, pose, noise(0.0), 1);
  // Downward beams at e deg reach the floor at 0.5 / sin(e): -15..-9 deg land within 1.9-3.2 m, -7 deg at
  // 4.1 m (beyond max range), the rest never.
  EXPECT_EQ(cloud.size(), 4u * static_cast<std::size_t>(lidar.columns));
  for (const auto& p : cloud.points) {
    EXPECT_GE(p.norm(), 1.0f);
    EXPECT_LE(p.norm(), 4.0f);
    EXPECT_NEAR(p.z(), -0.5f, 1e-4f);
  }
}

// With motion distortion each column is cast from its own pose, yet every point mapped through the
// end-of-sweep pose that the dataset reports must still land on a surface: the points are expressed in the
// end-of-sweep frame, like a driver's.
TEST(SimScan, MotionDistortedPointsAreInTheEndOfSweepFrame) {
  const RayCaster scene(office());
  const LidarModel lidar = LidarModel::vlp16(20.0);
  const Pose start = tsdf_mcl::pose_from_xyz_rpy(11.0, 10.2, 0.5, 0.0, 0.0, 0.0);
  const Pose end = tsdf_mcl::pose_from_xyz_rpy(12.0, 10.4, 0.5, 0.0, 0.05, 0.8);  // a fast, turning sweep
  const PointCloud moving = simulate_scan(scene, lidar, start, end, noise(0.0), 2);
  const PointCloud still = simulate_scan(scene, lidar, end, end, noise(0.0), 2);
  ASSERT_EQ(moving.size(), lidar.rays());
  ASSERT_EQ(still.size(), lidar.rays());
  double worst = 0.0, largest_shift = 0.0;
  for (std::size_t k = 0; k < moving.size(); k += 31) {
    worst = std::max(worst, tsdf_mcl::test::distance_to_mesh(office(), end * moving.points[k].cast<double>()));
    largest_shift = std::max(largest_shift, static_cast<double>((moving.points[k] - still.points[k]).norm()));
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_GT(largest_shift, 0.5);  // the sweep really is distorted
  // The last column fires at the end of the sweep: identical to the undistorted scan.
  for (std::size_t k = moving.size() - lidar.beams(); k < moving.size(); ++k) {
    EXPECT_LT((moving.points[k] - still.points[k]).norm(), 1e-4f);
  }
}

TEST(SimScan, SameKeySameScanWhateverTheThreadCount) {
  const RayCaster scene(office());
  const LidarModel lidar = LidarModel::vlp16(20.0);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const PointCloud one = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.02, 0.1), 42);
  omp_set_num_threads(std::max(2, threads));
  const PointCloud many = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.02, 0.1), 42);
  const PointCloud other = simulate_scan(scene, lidar, kCorridor, kCorridor, noise(0.02, 0.1), 43);
  omp_set_num_threads(threads);
  ASSERT_EQ(one.size(), many.size());
  EXPECT_EQ(one.points, many.points);
  EXPECT_EQ(one.intensity, many.intensity);
  EXPECT_NE(one.points, other.points);
}

TEST(SimScan, RayCasterRejectsBadMeshesAndReportsHits) {
  EXPECT_THROW(RayCaster(TriangleMesh{}), tsdf_mcl::Error);
  TriangleMesh broken;
  broken.vertices = {{0, 0, 0}, {1, 0, 0}};
  broken.triangles = {{0, 1, 2}};
  EXPECT_THROW(RayCaster{broken}, tsdf_mcl::Error);
  const RayCaster box(tsdf_mcl::test::box_mesh(Eigen::Vector3f(-1, -2, -3), Eigen::Vector3f(1, 2, 3)));
  EXPECT_EQ(box.triangle_count(), 12u);
  EXPECT_TRUE(box.bounds().min().isApprox(Eigen::Vector3f(-1, -2, -3)));
  const RayCaster::Hit hit = box.cast(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0), 10.0f);
  ASSERT_TRUE(hit.hit());
  EXPECT_FLOAT_EQ(hit.distance, 1.0f);
  EXPECT_TRUE(hit.normal.isApprox(Eigen::Vector3f(-1, 0, 0)));  // faces the ray's origin
  EXPECT_FALSE(box.cast(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0), 0.5f).hit());
}
