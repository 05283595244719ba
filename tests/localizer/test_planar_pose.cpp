// pose_from_planar (tsdf_mcl/localizer/planar_pose.hpp): an operator's planar pose completed from the map's floor and
// the scan.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "filter_test_scene.hpp"
#include "tsdf_mcl/localizer/planar_pose.hpp"

namespace tsdf_mcl {
namespace {

// RViz's "2D Pose Estimate" (x, y, yaw): z, roll and pitch from the map's floor and the scan. The sensor here is
// mounted 0.4 m above a level base and pitched 10 degrees: the base comes out level, at its own height.
TEST(PlanarPose, CompletesZRollAndPitchFromTheMapAndTheScan) {
  const TsdfMap map = test::make_office_map();
  const Pose truth = test::office_trajectory(30)[5];  // the sensor, level, above the floor
  const std::vector<double> floors = floors_under(map, truth.translation().x(), truth.translation().y());
  ASSERT_FALSE(floors.empty());
  EXPECT_NEAR(floors.front(), 0.0, 0.06) << "the office's floor is at z = 0";
  EXPECT_TRUE(floors_under(map, -100.0, 0.0).empty()) << "outside the map";

  const Pose base_T_sensor = pose_from_xyz_rpy(0.1, 0.0, 0.4, 0.0, 10.0 * M_PI / 180.0, 0.0);
  const Pose world_T_base = truth * pose_from_xyz_rpy(-0.1, 0.0, -0.4, 0.0, 0.0, 0.0);  // level
  // The scan as the tilted sensor sees it.
  const Pose world_T_sensor = world_T_base * base_T_sensor;
  Rng rng(3);
  const std::vector<Eigen::Vector3f> scan = test::simulate_scan(test::office_boxes(), world_T_sensor, rng);
  const double yaw = std::atan2(world_T_base.rotation()(1, 0), world_T_base.rotation()(0, 0));
  const auto pose =
      pose_from_planar(map, world_T_base.translation().x(), world_T_base.translation().y(), yaw, scan, base_T_sensor);
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR(pose->translation().z(), world_T_base.translation().z(), 0.1);
  const double tilt = std::acos(std::clamp(pose->rotation().col(2).dot(world_T_base.rotation().col(2)), -1.0, 1.0));
  EXPECT_LT(tilt, 3.0 * M_PI / 180.0) << "roll and pitch from the scan's up direction";
  EXPECT_LT(Eigen::AngleAxisd(pose->rotation().transpose() * world_T_base.rotation()).angle(), 3.0 * M_PI / 180.0);
  EXPECT_FALSE(pose_from_planar(map, 1.0, 1.0, 0.0, {}, Pose::Identity())) << "no scan: no floor height";
}

}  // namespace
}  // namespace tsdf_mcl
