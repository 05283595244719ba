// The node core driven in the test's own process (direct_link.hpp) through a simulated run: it localizes and keeps the
// last converged pose, a restarted core starts there, a last pose file that cannot be used is one warning, and the
// messages issue 52 found taken wrongly are refused (an off-map /initialpose, a quaternion whose norm overflows) or
// taken (ROS 1 stamps past 2^31 s).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "direct_link.hpp"
#include "hostile_scenario.hpp"
#include "scenario.hpp"
#include "tsdf_mcl/localizer/last_pose_file.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl::node::test {
namespace {

class LocalizationCoreRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    office_ = new fs::path(small_office());
    dir_ = new fs::path(fs::temp_directory_path() / ("tsdf_mcl_core_" + std::to_string(getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
  }
  static void TearDownTestSuite() {
    if (!::testing::UnitTest::GetInstance()->Failed()) fs::remove_all(*dir_);
    delete dir_;
    delete office_;
  }
  void SetUp() override {
    ASSERT_TRUE(fs::exists(*office_ / "complete")) << "the simulation failed; see " << *office_ / "cli.log";
    data_ = Dataset::open(*office_ / "run");
  }

  static NodeSettings settings(const fs::path& last_pose_file) {
    NodeSettings s;
    s.map_file = (*office_ / "map.tsdf").string();
    s.tf_timeout = 60.0;  // a wait ended by the transform's arrival: long only on a loaded machine
    s.map_cloud_points = 1000;
    s.last_pose_file = last_pose_file.string();
    return s;
  }
  static LocalizerOptions options() { return localizer_options_from({{"backend", "cpu"}, {"seed", "1"}}); }
  // Every `stride`-th scan of first..last (the motion between every second scan of the 20 Hz run is still small).
  std::vector<std::size_t> scans(std::size_t first, std::size_t last, std::size_t stride = 1) const {
    std::vector<std::size_t> out;
    for (std::size_t i = first; i < last && i < data_.size(); i += stride) out.push_back(i);
    return out;
  }

  static fs::path* office_;  // the shared simulated run and its map
  static fs::path* dir_;     // this test's own files
  Dataset data_;
};

fs::path* LocalizationCoreRun::office_ = nullptr;
fs::path* LocalizationCoreRun::dir_ = nullptr;

TEST_F(LocalizationCoreRun, LocalizesAndRestartsFromTheLastConvergedPose) {
  const fs::path file = *dir_ / "last_pose.json";
  fs::remove(file);
  const std::size_t n = data_.size();
  {
    DirectLink link(settings(file), options());
    EXPECT_GT(link.output().map_cloud_points(), 500u);
    EXPECT_LE(link.output().map_cloud_points(), 1000u);
    const Outcome o = summarize(play(link, data_, {scans(0, n, 2)}));
    std::printf("core, global: %s\n", describe(o).c_str());
    ASSERT_TRUE(o.first_converged) << describe(o);
    EXPECT_EQ(o.false_claims, 0u);
    EXPECT_LT(o.rmse_m, 0.1);
    EXPECT_GT(o.tf_checked, 5u);
    EXPECT_LT(o.max_tf_error_m, 0.2);
    EXPECT_LT(o.max_tf_error_deg, 3.0);
  }
  ASSERT_TRUE(fs::exists(file)) << "no last pose kept";
  // A restart where the run ended: the core starts at the kept pose, and its first estimate is right.
  DirectLink restarted(settings(file), options());
  EXPECT_TRUE(restarted.output().logged("starting at the last converged pose")) << restarted.output().all_logs();
  const std::vector<Played> played = play(restarted, data_, {scans(n - 3, n)});
  ASSERT_FALSE(played.empty());
  ASSERT_TRUE(played.front().heard && played.front().heard->pose);
  EXPECT_LT((played.front().heard->pose->pose.translation() - played.front().truth.translation()).norm(), 0.3);
  EXPECT_FALSE(restarted.output().logged("does not fit")) << restarted.output().all_logs();
}

TEST_F(LocalizationCoreRun, ALastPoseFileThatCannotBeUsedIsOneWarning) {
  const fs::path file = *dir_ / "bad_last_pose.json";
  {
    std::ofstream(file) << "{\"format\": \"something else\"}";
    DirectLink link(settings(file), options());
    EXPECT_TRUE(link.output().logged("not used: not a pose file of this version (corrupt?); searching the whole map"))
        << link.output().all_logs();
  }
  {
    std::ofstream(file) << "{\"format\": \"tsdf-mcl last pose 1\", \"map\": \"voxel 0.5 m\", \"x\": 0, \"y\": 0, "
                           "\"z\": 0, \"qx\": 0, \"qy\": 0, \"qz\": 0, \"qw\": 1}";
    DirectLink link(settings(file), options());
    EXPECT_TRUE(link.output().logged("written on another map (voxel 0.5 m)")) << link.output().all_logs();
  }
  // A pose on this map where the first scan does not fit: the core says so and searches the whole map.
  const TsdfMap map = load_map(*office_ / "map.tsdf");
  Pose wrong = data_.pose(0);
  wrong.translation().x() += 4.0;
  LastPoseFile(file, map).keep(wrong, 0.0);
  DirectLink link(settings(file), options());
  ASSERT_TRUE(link.output().logged("starting at the last converged pose")) << link.output().all_logs();
  PlayOptions until_converged{scans(0, data_.size(), 2)};
  until_converged.stop_after_converged = 5;
  const Outcome o = summarize(play(link, data_, until_converged));
  EXPECT_TRUE(link.output().logged("the first scan does not fit at the last converged pose"))
      << link.output().all_logs();
  ASSERT_TRUE(o.first_converged) << describe(o);
  EXPECT_EQ(o.false_claims, 0u);
}

TEST_F(LocalizationCoreRun, RefusesOffMapAndNonUnitInitialPosesAndTakesRos1StampsPast2038) {
  DirectLink link(settings(""), options());
  PlayOptions o{scans(0, 4)};
  // ROS 1 time runs to 2^32 s: a robot's clock past 2^31 s (2038) is a clock like any other.
  o.time_offset = 3.0e9 - data_.time(0);
  std::vector<Played> played = play(link, data_, o);
  ASSERT_EQ(played.size(), 4u);
  EXPECT_EQ(played.back().heard->count("rejected_messages"), 0u) << played.back().heard->value("last_rejection");
  EXPECT_EQ(played.back().heard->count("processed_scans"), 4u);

  const auto send = [&](const Eigen::Vector3d& position, const Eigen::Vector4d& quaternion) {
    InitialPoseMsg m;
    m.header.frame_id = "map";
    m.pose.position = position;
    m.pose.orientation = quaternion;
    link.initial_pose(m);
  };
  const auto next = [&](std::size_t i) {
    o.scans = {i};
    played = play(link, data_, o);
    return played.empty() || !played.front().heard ? Heard{} : *played.front().heard;
  };
  send({9.9e5, -9.9e5, 0}, {0, 0, 0, 1});
  Heard h = next(4);
  EXPECT_EQ(h.count("rejected_messages"), 1u);
  EXPECT_NE(
      h.value("last_rejection").find("/initialpose: position (990000.00, -990000.00, 0.00) m lies outside the map"),
      std::string::npos)
      << h.value("last_rejection");
  send(data_.pose(5).translation(), {1e200, 1e200, 0, 1e200});
  h = next(5);
  EXPECT_EQ(h.count("rejected_messages"), 2u);
  EXPECT_NE(h.value("last_rejection").find("is not of unit length"), std::string::npos) << h.value("last_rejection");
  EXPECT_EQ(h.count("initial_poses"), 0u);
  // A good one is taken at the next scan.
  const Eigen::Quaterniond q(data_.pose(6).rotation());
  send(data_.pose(6).translation(), {q.x(), q.y(), q.z(), q.w()});
  h = next(6);
  EXPECT_EQ(h.count("initial_poses"), 1u);
  ASSERT_TRUE(h.pose);
  EXPECT_LT((h.pose->pose.translation() - data_.pose(6).translation()).norm(), 0.3);
}

// The hostile messages both nodes' tests send over their transports, here straight into the core.
TEST_F(LocalizationCoreRun, SurvivesHostileMessages) {
  NodeSettings s = settings("");
  s.tf_timeout = 0.2;  // the default: the scenario's stalled odometry waits this long
  s.point_topics = {"/points"};
  s.odom_topic = "/odom";
  s.imu_topic = "/imu";
  s.sensor_extrinsics["lidar_b"] = pose_from_xyz_rpy(0, 0, 0.5, 0, 0, M_PI / 2);
  DirectLink link(s, localizer_options_from({{"backend", "cpu"}, {"particles", "3000"}, {"seed", "1"}}));
  run_hostile_scenario(link, {"sensor_extrinsics.lidar_b", "/odom", false});
}

}  // namespace
}  // namespace tsdf_mcl::node::test
