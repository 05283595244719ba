#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::Dataset;
using tsdf_mcl::Pose;
using tsdf_mcl::sim::RouteKind;
using tsdf_mcl::sim::SimulationOptions;
using tsdf_mcl::test::TempDir;

namespace {

SimulationOptions short_test_run(double length = 12.0) {
  SimulationOptions o;
  o.lidar = "vlp16";
  o.route = RouteKind::test;
  o.length_m = length;
  return o;
}

}  // namespace

TEST(SimSimulate, DatasetWriterRoundTrip) {
  TempDir dir;
  std::vector<tsdf_mcl::PointCloud> scans(3);
  std::vector<Pose> poses, odometry;
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 10 + i; ++k) {
      scans[i].points.emplace_back(0.1f * k, -0.5f * i, 1.0f / (k + 1));
      scans[i].intensity.push_back(0.01f * k);
    }
    poses.push_back(tsdf_mcl::pose_from_xyz_rpy(1.0 + i, 2.0, 0.5, 0.01 * i, -0.02 * i, 0.3 * i));
    odometry.push_back(tsdf_mcl::pose_from_xyz_rpy(0.9 * i, 0.1, 0.5, 0.0, 0.0, 0.29 * i));
  }
  {
    tsdf_mcl::DatasetWriter writer(dir.path());
    for (int i = 0; i < 3; ++i) writer.add(1e9 + 0.05 * i, scans[i], poses[i], odometry[i]);
    writer.close();
  }
  const Dataset ds = Dataset::open(dir.path());
  ASSERT_EQ(ds.size(), 3u);
  ASSERT_TRUE(ds.has_poses() && ds.has_odometry());
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(ds.time(i), 1e9 + 0.05 * static_cast<double>(i), 1e-6);
    EXPECT_TRUE(ds.pose(i).isApprox(poses[i], 1e-8));
    EXPECT_TRUE(ds.odometry(i).isApprox(odometry[i], 1e-8));
    const tsdf_mcl::PointCloud back = ds.load_scan(i);
    EXPECT_EQ(back.points, scans[i].points);
    EXPECT_EQ(back.intensity, scans[i].intensity);
  }
}

// The written scans, mapped through the written poses, lie on the written scene: times, poses, scans and
// scene.ply agree with each other.
TEST(SimSimulate, WritesAConsistentDataset) {
  TempDir dir;
  SimulationOptions o = short_test_run();
  o.noise.range_sigma = 0.0;
  const auto summary = tsdf_mcl::sim::simulate(o, dir.path());
  const Dataset ds = Dataset::open(dir.path());
  ASSERT_EQ(ds.size(), summary.scans);
  ASSERT_TRUE(ds.has_poses() && ds.has_odometry());
  EXPECT_NEAR(summary.route_length_m, 12.0, 0.1);
  EXPECT_EQ(summary.scans, static_cast<std::size_t>(std::floor(summary.duration_s * 20.0 + 1e-9)));
  for (std::size_t i = 0; i < ds.size(); ++i) EXPECT_NEAR(ds.time(i), 0.05 * static_cast<double>(i + 1), 1e-9);

  const tsdf_mcl::TriangleMesh scene = tsdf_mcl::load_mesh(dir / "scene.ply");
  std::size_t points = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < ds.size(); i += ds.size() / 5) {
    const tsdf_mcl::PointCloud cloud = ds.load_scan(i);
    EXPECT_GT(cloud.size(), 14000u);  // 14,400 rays at 20 Hz, all but a few hit the closed office
    for (std::size_t k = 0; k < cloud.size(); k += 97) {
      worst = std::max(worst, tsdf_mcl::test::distance_to_mesh(scene, ds.pose(i) * cloud.points[k].cast<double>()));
    }
  }
  for (std::size_t i = 0; i < ds.size(); ++i) points += ds.load_scan(i).size();
  EXPECT_EQ(points, summary.points);
  EXPECT_LT(worst, 1e-3);  // poses.txt carries 9 decimals

  std::ifstream in(dir / "simulation.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["lidar"]["name"], "vlp16");
  EXPECT_EQ(j["lidar"]["columns"], 900);
  EXPECT_EQ(j["route"]["kind"], "test");
  EXPECT_EQ(j["counts"]["scans"], summary.scans);
  EXPECT_EQ(j["scene"]["triangles"], scene.triangles.size());
}

TEST(SimSimulate, SeedDecidesEverything) {
  TempDir a, b, c;
  SimulationOptions o = short_test_run(6.0);
  tsdf_mcl::sim::simulate(o, a.path());
  tsdf_mcl::sim::simulate(o, b.path());
  o.seed = 2;
  tsdf_mcl::sim::simulate(o, c.path());
  for (const char* file : {"times.txt", "poses.txt", "odom.txt", "scans/000000.bin", "scans/000050.bin", "scene.ply"}) {
    EXPECT_EQ(tsdf_mcl::test::read_bytes(a / file), tsdf_mcl::test::read_bytes(b / file)) << file;
  }
  EXPECT_NE(tsdf_mcl::test::read_bytes(a / "poses.txt"), tsdf_mcl::test::read_bytes(c / "poses.txt"));
  const Dataset da = Dataset::open(a.path()), dc = Dataset::open(c.path());
  EXPECT_GT((da.pose(0).translation() - dc.pose(0).translation()).norm(), 1.0);  // another route
}

TEST(SimSimulate, OdometryDriftsButStaysBounded) {
  TempDir dir;
  SimulationOptions o = short_test_run(25.0);
  o.lidar = "os0-64";
  o.scan_spacing_m = 0.5;  // odometry still integrates every sweep; only fewer scans are written
  tsdf_mcl::sim::simulate(o, dir.path());
  const Dataset ds = Dataset::open(dir.path());
  ASSERT_GT(ds.size(), 40u);
  const tsdf_mcl::test::StepErrors steps = tsdf_mcl::test::odometry_step_errors(ds);
  // The first odometry pose is the sensor above the odom origin.
  EXPECT_LT((ds.odometry(0).translation() - Eigen::Vector3d(0, 0, 0.5)).norm(), 1e-6);
  const Pose truth = ds.pose(0).inverse() * ds.pose(ds.size() - 1);
  const Pose odom = ds.odometry(0).inverse() * ds.odometry(ds.size() - 1);
  const double drift = (truth.translation() - odom.translation()).norm();
  EXPECT_GT(drift, 0.01);
  EXPECT_LT(drift, 0.15 * 25.0);
  EXPECT_GT(steps.error, 0.02 * steps.length);
  EXPECT_LT(steps.error, 0.5 * steps.length);

  TempDir exact_dir;
  o.odometry.relative = 0.0;
  tsdf_mcl::sim::simulate(o, exact_dir.path());
  const Dataset exact = Dataset::open(exact_dir.path());
  const Pose exact_motion = exact.odometry(0).inverse() * exact.odometry(exact.size() - 1);
  const Pose exact_truth = exact.pose(0).inverse() * exact.pose(exact.size() - 1);
  EXPECT_TRUE(exact_motion.isApprox(exact_truth, 1e-6));
}

TEST(SimSimulate, ObstaclesStandBesideTheRouteAndAreSeen) {
  TempDir dir;
  SimulationOptions o = short_test_run(15.0);
  o.obstacles = 4;
  o.noise.range_sigma = 0.0;
  tsdf_mcl::sim::simulate(o, dir.path());
  std::ifstream in(dir / "simulation.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["obstacles"].size(), 4u);
  EXPECT_EQ(j["scene"]["triangles"], tsdf_mcl::sim::office_scene(1).triangles.size() + 4 * 12);
  const Dataset ds = Dataset::open(dir.path());
  std::size_t on_obstacles = 0;
  for (const auto& box : j["obstacles"]) {
    const Eigen::Vector3d lo(box["min"][0], box["min"][1], box["min"][2]);
    const Eigen::Vector3d hi(box["max"][0], box["max"][1], box["max"][2]);
    EXPECT_NEAR(hi.z() - lo.z(), 1.82, 1e-4);
    EXPECT_NEAR(hi.x() - lo.x(), 0.5, 1e-4);
    const Eigen::AlignedBox2d footprint(lo.head<2>(), hi.head<2>());
    for (std::size_t i = 0; i < ds.size(); ++i) {
      EXPECT_GT(footprint.exteriorDistance(ds.pose(i).translation().head<2>()), 0.3) << "the robot drives into it";
    }
    const Eigen::AlignedBox3d shell(lo - Eigen::Vector3d::Constant(1e-3), hi + Eigen::Vector3d::Constant(1e-3));
    for (std::size_t i = 0; i < ds.size(); i += 10) {
      const tsdf_mcl::PointCloud cloud = ds.load_scan(i);
      for (const auto& p : cloud.points) on_obstacles += shell.contains(ds.pose(i) * p.cast<double>());
    }
  }
  EXPECT_GT(on_obstacles, 100u);
}

TEST(SimSimulate, MappingRunKeepsScansApart) {
  TempDir dir;
  SimulationOptions o;
  o.route = RouteKind::mapping;
  o.lidar = "os0-64";
  o.length_m = 20.0;
  o.scan_spacing_m = 0.5;
  tsdf_mcl::sim::simulate(o, dir.path());
  const Dataset ds = Dataset::open(dir.path());
  ASSERT_GT(ds.size(), 20u);
  for (std::size_t i = 1; i < ds.size(); ++i) {
    const Pose step = ds.pose(i - 1).inverse() * ds.pose(i);
    const bool moved = step.translation().norm() >= 0.5 - 1e-6;
    const bool turned = Eigen::AngleAxisd(step.linear()).angle() >= 30.0 * M_PI / 180.0 - 1e-6;
    EXPECT_TRUE(moved || turned) << "scan " << i;
  }
}

TEST(SimSimulate, RejectsBadOptions) {
  TempDir dir;
  auto message = [&](const SimulationOptions& o) {
    try {
      tsdf_mcl::sim::simulate(o, dir / "out");
    } catch (const tsdf_mcl::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SimulationOptions o = short_test_run();
  o.obstacles = 2;
  o.route = RouteKind::mapping;
  EXPECT_NE(message(o).find("obstacles"), std::string::npos);
  o = short_test_run();
  o.duration_s = 10.0;
  EXPECT_NE(message(o).find("not both"), std::string::npos);
  o = short_test_run();
  o.noise.dropout = 1.0;
  EXPECT_NE(message(o).find("dropout"), std::string::npos);
  o = short_test_run();
  o.scene = (dir / "missing.stl").string();
  EXPECT_NE(message(o).find("missing.stl"), std::string::npos);
  o = short_test_run();
  o.lidar = "hdl64";
  EXPECT_NE(message(o).find("hdl64"), std::string::npos);
}

TEST(SimSimulate, AvzMeshGivesScans) {
  const auto file = tsdf_mcl::test::shared_data() / "avz" / "avz_no_roof.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data " << file << " is not available";
  for (const double ground : {std::numeric_limits<double>::quiet_NaN(), 0.0}) {
    TempDir dir;
    SimulationOptions o = short_test_run(4.0);
    o.scene = file.string();
    o.ground_plane_z = ground;
    const auto summary = tsdf_mcl::sim::simulate(o, dir.path());
    const Dataset ds = Dataset::open(dir.path());
    ASSERT_EQ(ds.size(), summary.scans);
    EXPECT_GT(ds.size(), 50u);
    // Without a roof over most of the building some beams may see the sky, but most return.
    EXPECT_GT(ds.load_scan(ds.size() / 2).size(), 7200u);
    EXPECT_NEAR(summary.route_length_m, 4.0, 0.1);
  }
}
