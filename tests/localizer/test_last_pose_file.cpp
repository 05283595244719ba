// The last converged pose kept across runs (last_pose_file.hpp): written atomically at most once a second, read back
// only for the map it was written on and only where it lies on it; the first update's test of the fit.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/localizer/last_pose_file.hpp"

namespace tsdf_mcl {
namespace {

using test::TempDir;

// 0..8 m, 0..8 m, 0..1.6 m; another map differs in its box.
TsdfMap small_map(int blocks = 10) {
  return TsdfMap(0.1f, 0.3f, Eigen::Vector3i(0, 0, 0), Eigen::Vector3i(blocks, 10, 2));
}

TEST(LastPoseFile, KeepsAPoseForItsMapOnly) {
  TempDir dir;
  const TsdfMap map = small_map();
  LastPoseFile last(dir / "pose.json", map);
  std::string warning;
  EXPECT_FALSE(last.load(&warning));
  EXPECT_EQ(warning, "") << "no file is no warning";

  const Pose pose = pose_from_xyz_rpy(2.0, 3.0, 0.5, 0.0, 0.0, 1.0);
  EXPECT_TRUE(last.keep(pose, 10.0));
  EXPECT_FALSE(last.keep(pose_from_xyz_rpy(2.5, 3.0, 0.5, 0, 0, 1.0), 10.1)) << "within a second of the last write";
  const auto back = LastPoseFile(dir / "pose.json", map).load(&warning);
  ASSERT_TRUE(back) << warning;
  EXPECT_LT((back->matrix() - pose.matrix()).cwiseAbs().maxCoeff(), 1e-12);

  const TsdfMap other = small_map(12);
  EXPECT_FALSE(LastPoseFile(dir / "pose.json", other).load(&warning));
  EXPECT_NE(warning.find("not used: written on another map"), std::string::npos) << warning;

  last.keep_now(pose_from_xyz_rpy(50.0, 3.0, 0.5, 0, 0, 0), 11.0);  // off the map
  EXPECT_FALSE(LastPoseFile(dir / "pose.json", map).load(&warning));
  EXPECT_NE(warning.find("its pose lies off the map"), std::string::npos) << warning;

  std::ofstream(dir / "pose.json") << "{\"format\": \"tsdf-mcl last pose 1\"";
  EXPECT_FALSE(LastPoseFile(dir / "pose.json", map).load(&warning));
  EXPECT_NE(warning.find("not a pose file of this version (corrupt?)"), std::string::npos) << warning;
  EXPECT_EQ(warning.find('\n'), std::string::npos);
}

TEST(LastPoseFile, StartsThereUnlessTheOptionsHaveAPose) {
  TempDir dir;
  const TsdfMap map = small_map();
  LastPoseFile last(dir / "pose.json", map);
  last.keep_now(pose_from_xyz_rpy(2.0, 3.0, 0.5, 0, 0, 0), 1.0);
  std::string note, warning;
  LocalizerOptions options;
  ASSERT_TRUE(last.start(options, &note, &warning));
  EXPECT_EQ(note.rfind("starting at the last converged pose (2.00, 3.00, 0.50, yaw 0.0 deg) from ", 0), 0u) << note;
  options.initial_pose = Pose::Identity();
  note.clear();
  EXPECT_FALSE(last.start(options, &note, &warning));
  EXPECT_EQ(note, "");
  last.flush();  // nothing held back: no write, no error
}

TEST(LastPoseFile, TheFirstUpdateTellsAMisfit) {
  LocalizerOptions options;
  options.filter.states.min_inliers = 0.5;
  FilterStep step;
  step.estimate.pose = pose_from_xyz_rpy(1.2, 0, 0, 0, 0, 0);
  step.estimate.inlier_ratio = 0.9;
  EXPECT_EQ(initial_pose_misfit(step, options, Pose::Identity()),
            "the best place after the first update lies 1.2 m from it");
  step.estimate.pose = pose_from_xyz_rpy(0.3, 0, 0, 0, 0, 0);
  EXPECT_EQ(initial_pose_misfit(step, options, Pose::Identity()), "");
  step.estimate.inlier_ratio = 0.2;
  EXPECT_NE(initial_pose_misfit(step, options, Pose::Identity()).find("20 % of its points lie within"),
            std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl
