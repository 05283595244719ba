#include <gtest/gtest.h>

#include <cmath>

#include "tsdf_mcl/sim/platform.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::Pose;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::Platform;
using tsdf_mcl::sim::RobotModel;
using tsdf_mcl::sim::Route;
using tsdf_mcl::sim::SensorTrajectory;

namespace {

constexpr double kDeg = M_PI / 180.0;

const tsdf_mcl::test::SceneOnGrid& office() { return tsdf_mcl::test::office_on_grid(); }

// A 40 m test route of the office (over a ramp) at the platform's speed.
Route route_for(Platform platform, std::uint64_t seed = 1) {
  return tsdf_mcl::sim::plan_route(office().grid, office().scene, RobotModel::of(platform),
                                   tsdf_mcl::sim::RouteKind::test, seed, 40.0)
      .truncated(0.0, 40.0);
}

double heading_of(const Pose& p) { return std::atan2(p.linear()(1, 0), p.linear()(0, 0)); }
double tilt_of(const Pose& p) { return std::acos(std::min(1.0, p.linear()(2, 2))); }
double angle_between(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * M_PI)); }

}  // namespace

TEST(SimPlatform, GroundRobotCarriesTheSensorAboveItsBase) {
  const Route route = route_for(Platform::ground);
  const RobotModel robot;
  const SensorTrajectory level(route, office().scene, Platform::ground, robot, 0.0, 1);
  const SensorTrajectory tilted(route, office().scene, Platform::ground, robot, 10.0, 1);
  for (double t = 0.0; t < route.duration(); t += 0.37) {
    Pose expected = route.base_pose(t);
    expected.translation() += expected.linear().col(2) * robot.sensor_height;
    EXPECT_TRUE(level.sensor_pose(t).isApprox(expected, 1e-12)) << "t " << t;
    // The tilt turns the sensor about its own y axis: x towards the floor.
    const Pose tilt = expected.inverse() * tilted.sensor_pose(t);
    EXPECT_LT(tilt.translation().norm(), 1e-12);
    EXPECT_TRUE(tilt.linear().isApprox(Eigen::AngleAxisd(10.0 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix()));
  }
  const Pose flat = tilted.sensor_pose(0.0);
  EXPECT_NEAR(flat.linear()(2, 0), -std::sin(10.0 * kDeg), 1e-6);
}

// Upright 1.5 m above the floor, bobbing 2.5 cm at the step frequency (1.85 Hz at 1.2 m/s), tilting a few
// degrees, its yaw within a few degrees of the walking direction.
TEST(SimPlatform, HandheldSensorSwaysWithTheGait) {
  const Route route = route_for(Platform::handheld);
  const RobotModel robot = RobotModel::of(Platform::handheld);
  const SensorTrajectory walk(route, office().scene, Platform::handheld, robot, 0.0, 1);
  double low = 1e9, high = -1e9, max_tilt = 0.0, max_yaw_off = 0.0, cruising = 0.0;
  int crossings = 0;
  double last_bob = 0.0;
  const double dt = 0.01;
  for (double t = 0.0; t < route.duration(); t += dt) {
    const Pose sensor = walk.sensor_pose(t), base = route.base_pose(t);
    const double height = sensor.translation().z() - base.translation().z();
    low = std::min(low, height);
    high = std::max(high, height);
    max_tilt = std::max(max_tilt, tilt_of(sensor));
    max_yaw_off = std::max(max_yaw_off, angle_between(heading_of(sensor), heading_of(base)));
    EXPECT_LT((sensor.translation() - base.translation()).head<2>().norm(), 1e-9);
    const double speed = (route.distance_at(t + dt) - route.distance_at(t)) / dt;
    if (speed > 0.98 * robot.speed) {
      cruising += dt;
      crossings += (height - 1.5) * last_bob < 0.0;
    }
    last_bob = height - 1.5;
  }
  EXPECT_GT(low, 1.5 - 0.0251);
  EXPECT_LT(high, 1.5 + 0.0251);
  EXPECT_GT(high - low, 0.04);
  EXPECT_GT(max_tilt, 2.0 * kDeg);
  EXPECT_LT(max_tilt, 5.0 * kDeg);
  EXPECT_LT(max_yaw_off, 3.6 * kDeg);
  ASSERT_GT(cruising, 10.0);
  const double step_frequency = crossings / 2.0 / cruising;
  EXPECT_GT(step_frequency, 1.6);
  EXPECT_LT(step_frequency, 2.1);
}

// 1.0-2.5 m above the floor, lower only under lintels and never closer than 0.35 m below anything; tilted
// into its acceleration by up to 20 deg; looking away from the path at times.
TEST(SimPlatform, DroneFliesUnderTheHeadroomAndTiltsWithItsAcceleration) {
  const Route route = route_for(Platform::drone);
  const SensorTrajectory flight(route, office().scene, Platform::drone, RobotModel::of(Platform::drone), 0.0, 1);
  double low = 1e9, high = -1e9, max_tilt = 0.0, in_band = 0.0, total = 0.0, nearest_above = 1e9;
  int accelerating = 0, leaning_into_it = 0, looking_away = 0, looking_ahead = 0;
  const double dt = 0.05, h = 0.25;
  for (double t = h; t + h < route.duration(); t += dt) {
    const Pose sensor = flight.sensor_pose(t), base = route.base_pose(t);
    const double height = sensor.translation().z() - base.translation().z();
    low = std::min(low, height);
    high = std::max(high, height);
    in_band += dt * (height >= 1.0 - 1e-9 && height <= 2.5 + 1e-9);
    total += dt;
    max_tilt = std::max(max_tilt, tilt_of(sensor));
    nearest_above = std::min(
        nearest_above,
        double(office().scene.cast(sensor.translation().cast<float>(), Eigen::Vector3f::UnitZ(), 10.0f).distance));
    const Eigen::Vector3d a = (flight.sensor_pose(t + h).translation() - 2.0 * sensor.translation() +
                               flight.sensor_pose(t - h).translation()) /
                              (h * h);
    if (a.head<2>().norm() > 1.0) {
      ++accelerating;
      leaning_into_it += sensor.linear().col(2).head<2>().normalized().dot(a.head<2>().normalized()) > 0.7;
    }
    const double moving = (route.distance_at(t + dt) - route.distance_at(t)) / dt;
    if (moving > 0.5) {
      const double off = angle_between(heading_of(sensor), heading_of(base));
      looking_away += off > 30.0 * kDeg;
      looking_ahead += off < 5.0 * kDeg;
    }
  }
  EXPECT_GE(low, 0.5);
  EXPECT_LE(high, 2.5 + 1e-9);
  EXPECT_GT(high - low, 0.5);
  EXPECT_GT(in_band / total, 0.8);
  EXPECT_GE(nearest_above, 0.34);
  EXPECT_LE(max_tilt, 20.0 * kDeg + 1e-9);
  EXPECT_GT(max_tilt, 5.0 * kDeg);
  ASSERT_GT(accelerating, 20);
  EXPECT_GT(leaning_into_it, 0.8 * accelerating);
  EXPECT_GT(looking_away, 20);
  EXPECT_GT(looking_ahead, 20);
}

TEST(SimPlatform, SeedDecidesTheSwayAndTheFlight) {
  for (const Platform platform : {Platform::handheld, Platform::drone}) {
    const Route route = route_for(platform);
    const RobotModel robot = RobotModel::of(platform);
    const SensorTrajectory a(route, office().scene, platform, robot, 0.0, 5),
        b(route, office().scene, platform, robot, 0.0, 5), c(route, office().scene, platform, robot, 0.0, 6);
    double differ = 0.0;
    for (double t = 0.0; t < route.duration(); t += 0.5) {
      EXPECT_TRUE(a.sensor_pose(t).isApprox(b.sensor_pose(t), 0.0));
      differ =
          std::max(differ, (a.sensor_pose(t).translation() - c.sensor_pose(t).translation()).norm() +
                               tsdf_mcl::rotation_angle_between(a.sensor_pose(t).linear(), c.sensor_pose(t).linear()));
    }
    EXPECT_GT(differ, 0.01);
  }
}

// poses.txt holds the carried sensor; odometry starts at the sensor's pose over the base and follows the
// sensor's own motion with drift.
TEST(SimPlatform, RunsWriteTheCarriedSensorAndItsOdometry) {
  for (const Platform platform : {Platform::handheld, Platform::drone}) {
    tsdf_mcl::test::TempDir dir;
    tsdf_mcl::sim::SimulationOptions o;
    o.platform = platform;
    o.robot = RobotModel::of(platform);
    o.rate_hz = 10.0;
    o.length_m = 10.0;
    o.scan_spacing_m = 0.2;
    o.noise.range_sigma = 0.0;
    o.sensor_tilt_deg = 5.0;
    tsdf_mcl::sim::simulate(o, dir.path());
    const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir.path());
    ASSERT_GT(ds.size(), 30u);
    const double first_height = ds.odometry(0).translation().z();
    if (platform == Platform::handheld) {
      EXPECT_NEAR(first_height, 1.5, 0.026);
    } else {
      EXPECT_TRUE(first_height >= 0.5 && first_height <= 2.5) << first_height;
    }
    const tsdf_mcl::test::StepErrors steps = tsdf_mcl::test::odometry_step_errors(ds);
    EXPECT_GT(steps.error, 0.02 * steps.length);
    EXPECT_LT(steps.error, 0.5 * steps.length);
    // Exact scans mapped through poses.txt lie on the scene.
    const TriangleMesh scene = tsdf_mcl::load_mesh(dir / "scene.ply");
    double worst = 0.0;
    for (std::size_t i = 0; i < ds.size(); i += ds.size() / 4) {
      const tsdf_mcl::PointCloud cloud = ds.load_scan(i);
      EXPECT_GT(cloud.size(), 14000u);
      for (std::size_t k = 0; k < cloud.size(); k += 211) {
        worst = std::max(worst, tsdf_mcl::test::distance_to_mesh(scene, ds.pose(i) * cloud.points[k].cast<double>()));
      }
    }
    EXPECT_LT(worst, 1e-3);
  }
}
