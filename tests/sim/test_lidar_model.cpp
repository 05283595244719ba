#include <gtest/gtest.h>

#include <cmath>

#include "sim_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::Error;
using tsdf_mcl::Pose;
using tsdf_mcl::sim::LidarModel;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::ScanNoise;

namespace {

constexpr double kDeg = M_PI / 180.0;

double elevation_deg(const Eigen::Vector3f& p) {
  return std::atan2(static_cast<double>(p.z()), std::hypot(static_cast<double>(p.x()), static_cast<double>(p.y()))) /
         kDeg;
}

}  // namespace

TEST(SimLidar, Vlp16BeamsAndColumnsFollowTheRate) {
  const LidarModel at20 = LidarModel::vlp16(20.0);
  ASSERT_EQ(at20.beams(), 16u);
  for (std::size_t b = 0; b < 16; ++b) EXPECT_DOUBLE_EQ(at20.elevations_deg[b], -15.0 + 2.0 * static_cast<double>(b));
  EXPECT_EQ(at20.columns, 900);  // 0.4 deg at 20 Hz
  EXPECT_NEAR((at20.azimuth_of(0) - at20.azimuth_of(1)) / kDeg, 0.4, 1e-12);
  const LidarModel at10 = LidarModel::vlp16(10.0);
  EXPECT_EQ(at10.columns, 1800);  // 0.2 deg at 10 Hz
  EXPECT_EQ(at10.rays(), 28800u);
  EXPECT_DOUBLE_EQ(at10.min_range, 0.5);
  EXPECT_DOUBLE_EQ(at10.max_range, 100.0);
  EXPECT_THROW(LidarModel::vlp16(30.0), Error);
  EXPECT_THROW(LidarModel::vlp16(0.0), Error);
}

TEST(SimLidar, Os0BeamsSpreadEvenlyOverNinetyDegrees) {
  const LidarModel m = LidarModel::os0_64();
  ASSERT_EQ(m.beams(), 64u);
  EXPECT_EQ(m.columns, 1024);
  EXPECT_EQ(m.rays(), 65536u);
  EXPECT_NEAR(m.elevations_deg.front(), -45.0, 1e-12);
  EXPECT_NEAR(m.elevations_deg.back(), 45.0, 1e-12);
  for (std::size_t b = 1; b < 64; ++b) EXPECT_NEAR(m.elevations_deg[b] - m.elevations_deg[b - 1], 90.0 / 63.0, 1e-9);
  EXPECT_NEAR((m.azimuth_of(0) - m.azimuth_of(1)) / kDeg, 360.0 / 1024.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.rate_hz, 10.0);
  EXPECT_THROW(LidarModel::os0_64(15.0), Error);
}

TEST(SimLidar, DirectionsAreUnitAndSpinClockwise) {
  const LidarModel m = LidarModel::vlp16(10.0);
  const Eigen::Vector3f first = m.direction(7, 0);  // beam 7: -1 deg
  EXPECT_NEAR(first.norm(), 1.0f, 1e-6f);
  EXPECT_GT(first.x(), 0.99f);
  EXPECT_NEAR(elevation_deg(first), -1.0, 1e-5);
  const Eigen::Vector3f quarter = m.direction(8, m.columns / 4);  // a quarter turn later: looking along -y
  EXPECT_LT(quarter.y(), -0.99f);
  EXPECT_NEAR(elevation_deg(quarter), 1.0, 1e-5);
}

TEST(SimLidar, BeamTableFileIsParsedAndChecked) {
  tsdf_mcl::test::TempDir dir;
  const auto file = dir / "my_lidar.txt";
  tsdf_mcl::test::write_bytes(file,
                              "# a 4-beam test LiDAR\n"
                              "columns 360   # one degree\n"
                              "min_range 0.2\n"
                              "max_range 30\n"
                              "rate 5\n"
                              "  10.5\n-10\n0\n 2.25 # beams in any order\n\n");
  const LidarModel m = LidarModel::from_name(file.string());
  EXPECT_EQ(m.name, "my_lidar");
  EXPECT_EQ(m.columns, 360);
  EXPECT_DOUBLE_EQ(m.min_range, 0.2);
  EXPECT_DOUBLE_EQ(m.max_range, 30.0);
  EXPECT_DOUBLE_EQ(m.rate_hz, 5.0);
  EXPECT_EQ(m.elevations_deg, (std::vector<double>{-10.0, 0.0, 2.25, 10.5}));
  EXPECT_DOUBLE_EQ(LidarModel::from_name(file.string(), 12.0).rate_hz, 12.0);

  auto message_of = [&](const std::string& text) {
    tsdf_mcl::test::write_bytes(file, text);
    try {
      LidarModel::from_beam_table(file);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of("min_range 0.2\nmax_range 30\n5\n").find("columns"), std::string::npos);
  EXPECT_NE(message_of("columns 100\nmin_range 0.2\nmax_range 30\n").find("no beam"), std::string::npos);
  EXPECT_NE(message_of("columns 100\nmin_range 0.2\nmax_range 30\nfive\n").find("my_lidar.txt:4"), std::string::npos);
  EXPECT_NE(message_of("columns 100\nmin_range 0.2\nmax_range 30\n95\n").find("outside"), std::string::npos);
  EXPECT_NE(message_of("columns 1.5\nmin_range 0.2\nmax_range 30\n5\n").find("integer"), std::string::npos);
  EXPECT_THROW(LidarModel::from_name("velodyne-hdl64"), Error);
}

// Inside a box within both models' range every ray returns, so each point's elevation and azimuth must be exactly its
// beam's and column's, whatever the sensor's orientation.
TEST(SimLidar, SimulatedPointsHaveTheModelsBeamAngles) {
  const RayCaster box(tsdf_mcl::test::box_mesh(Eigen::Vector3f(-25, -25, -25), Eigen::Vector3f(25, 25, 25)));
  ScanNoise exact;
  exact.range_sigma = 0.0;
  for (const LidarModel& m : {LidarModel::vlp16(10.0), LidarModel::os0_64()}) {
    const Pose pose = tsdf_mcl::pose_from_xyz_rpy(3.0, -2.0, 1.0, 0.2, -0.3, 1.1);
    const tsdf_mcl::PointCloud cloud = tsdf_mcl::sim::simulate_scan(box, m, pose, pose, exact, 7);
    ASSERT_EQ(cloud.size(), m.rays()) << m.name;
    for (std::size_t k = 0; k < cloud.size(); k += 7) {
      const int column = static_cast<int>(k / m.beams());
      const std::size_t beam = k % m.beams();
      const Eigen::Vector3f& p = cloud.points[k];
      ASSERT_NEAR(elevation_deg(p), m.elevations_deg[beam], 1e-3) << m.name << " point " << k;
      const double azimuth = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x()));
      ASSERT_NEAR(std::remainder(azimuth - m.azimuth_of(column), 2 * M_PI), 0.0, 1e-4) << m.name << " point " << k;
      ASSERT_GE(cloud.intensity[k], 0.0f);
      ASSERT_LE(cloud.intensity[k], 1.0f);
    }
  }
}
