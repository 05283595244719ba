// The evaluate command on the office fixture's dataset, and its answers to bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::fixture;
using test::Fixture;
using test::run_cli;
using test::TempDir;

TEST(CliEvaluate, BadInputGivesOneClearError) {
  const Fixture& f = fixture();
  TempDir out;
  test::write_bytes(out / "late.tum", "1630577999.0 0 0 0 0 0 0 1\n");
  expect_one_line_error(out, "evaluate --estimate " + (out / "late.tum").string() + " --dataset " + f.dataset,
                        "no ground-truth pose within");
  test::write_bytes(out / "garbage.tum", "1630577758.569490 0 0 zero\n");
  expect_one_line_error(out, "evaluate --estimate " + (out / "garbage.tum").string() + " --dataset " + f.dataset,
                        "garbage.tum:1");
  const std::filesystem::path no_truth = out / "no_truth";
  std::filesystem::copy(f.dataset, no_truth, std::filesystem::copy_options::recursive);
  std::filesystem::remove(no_truth / "poses.txt");
  expect_one_line_error(out, "evaluate --estimate " + (out / "late.tum").string() + " --dataset " + no_truth.string(),
                        "has no poses.txt");
}

// A run that was right, then 5 m off for 4 s (a lost track), then right again; in a simulated mirror building whose
// landmark it first sees at scan 12, evaluate judges the scans from there on apart ("after_landmark").
TEST(CliEvaluate, LostTracksAndScansAfterTheLandmark) {
  const Fixture& f = fixture();
  TempDir out;
  const std::filesystem::path data = out / "data";
  std::filesystem::copy(f.dataset, data, std::filesystem::copy_options::recursive);
  const Dataset truth = Dataset::open(data);
  std::vector<StampedPose> estimate;
  for (std::size_t i = 0; i < truth.times().size(); ++i) {
    Pose p = truth.poses()[i];
    if (i >= 4 && i < 12) p.translation().x() += 5.0;
    if (i >= 14 && i < 16) p.translation().y() += 0.5;  // off, not lost
    estimate.push_back({truth.times()[i], p});
  }
  write_tum(out / "run.tum", estimate);
  const std::string args = "evaluate --estimate " + (out / "run.tum").string() + " --dataset " + data.string();

  CliResult e = run_cli(out, args);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  auto m = nlohmann::json::parse(e.out);
  EXPECT_EQ(m["lost_tracks"]["episodes"], 1);
  EXPECT_EQ(m["lost_tracks"]["first_scan"], 4);
  EXPECT_FALSE(m.contains("after_landmark"));  // no simulation.json: nothing to say
  EXPECT_NE(e.err.find("LOST TRACK"), std::string::npos) << e.err;
  // A longer bar than the episode lasted: no lost track.
  e = run_cli(out, args + " --lost_duration 4.5");
  EXPECT_EQ(nlohmann::json::parse(e.out)["lost_tracks"]["episodes"], 0);
  expect_one_line_error(out, args + " --lost_duration -1", "--lost_duration");

  test::write_bytes(data / "simulation.json",
                    R"({"landmark": {"name": "display cabinet", "first_seen_scan": 12, "first_seen_time_s": 6.0}})");
  e = run_cli(out, args);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  m = nlohmann::json::parse(e.out);
  const auto& after = m["after_landmark"];
  EXPECT_EQ(after["landmark"], "display cabinet");
  EXPECT_EQ(after["first_seen_scan"], 12);
  EXPECT_NEAR(after["first_seen_time_s"].get<double>(), 6.0, 1e-6);
  EXPECT_EQ(after["scans"], truth.times().size() - 12);
  EXPECT_NEAR(after["localized_fraction"].get<double>(), 1.0 - 2.0 / static_cast<double>(truth.times().size() - 12),
              1e-9);
  EXPECT_EQ(after["lost_tracks"], 0);
  EXPECT_EQ(after["localized_from"]["scan"], 16);
  EXPECT_NE(e.err.find("from the first sight of the display cabinet (scan 12) on"), std::string::npos) << e.err;

  // Never seen: the figures are null and the verdict says the wing is a guess.
  test::write_bytes(data / "simulation.json", R"({"landmark": {"name": "display cabinet", "first_seen_scan": null}})");
  e = run_cli(out, args);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_TRUE(nlohmann::json::parse(e.out)["after_landmark"]["localized_fraction"].is_null());
  EXPECT_NE(e.err.find("never sees the display cabinet"), std::string::npos) << e.err;
  // A broken description is said and skipped: the metrics do not depend on it.
  test::write_bytes(data / "simulation.json", R"({"landmark": {"first_seen_scan": "twelve"}})");
  e = run_cli(out, args);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_FALSE(nlohmann::json::parse(e.out).contains("after_landmark"));
  EXPECT_NE(e.err.find("the landmark is not checked"), std::string::npos) << e.err;
}

}  // namespace
}  // namespace tsdf_mcl
