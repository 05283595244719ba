// The localize, evaluate and bench commands end to end on a small synthetic dataset, and their answers to bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <map>
#include <sstream>
#include <string>

#include "tsdf_mcl/filter/track_state.hpp"
#include "filter_test_scene.hpp"
#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::run_cli;

using test::fixture;
using test::Fixture;
using test::kT0;
using test::TempDir;

std::string last_line(const std::string& text) {
  std::string s = text;
  while (!s.empty() && s.back() == '\n') s.pop_back();
  const auto nl = s.rfind('\n');
  return nl == std::string::npos ? s : s.substr(nl + 1);
}

// Errors found while scans are processed come after the progress lines: the last line names them.
void expect_error_last(const TempDir& dir, const std::string& args, const std::string& words) {
  const CliResult r = run_cli(dir, args);
  EXPECT_NE(r.exit_code, 0) << args;
  EXPECT_NE(last_line(r.err).find(words), std::string::npos)
      << args << ": '" << last_line(r.err) << "' lacks '" << words << "'";
  EXPECT_NE(last_line(r.err).find("error"), std::string::npos) << r.err;
}

const std::string kGroundRobot =
    " --backend cpu --particles 20000 --max_particles 20000 --min_particles 300 --init_max_tilt 0.1"
    " --init_height_band 0.6,1.2 --max_beams 256 --update_min_d 0 --update_min_a 0";

// A platform with an IMU: imu.txt beside the scans (100 Hz, the specific force at rest plus noise, sensor frame)
// gives the up direction, so the global search has one candidate instead of the scan's several. No other prior.
TEST(CliLocalize, ImuGravityGuidesThePriorFreeGlobalSearch) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string data = (out / "office").string();
  std::filesystem::copy(f.dataset, data, std::filesystem::copy_options::recursive);
  const std::vector<Pose> truth = test::office_trajectory(24);
  std::ofstream imu(out / "office/imu.txt");
  imu << "# t ax ay az wx wy wz\n";
  Rng rng(8);
  for (std::size_t i = 0; i < 24; ++i) {
    for (int k = -5; k < 5; ++k) {
      const Eigen::Vector3d a = truth[i].linear().transpose() * Eigen::Vector3d(0, 0, 9.81) +
                                Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()) * 0.05;
      char line[160];
      std::snprintf(line, sizeof(line), "%.6f %.5f %.5f %.5f 0 0 0\n", kT0 + 0.5 * static_cast<double>(i) + 0.01 * k,
                    a.x(), a.y(), a.z());
      imu << line;
    }
  }
  imu.close();
  const std::string o = (out / "run").string();
  const std::string args =
      "localize --map " + f.map + " --dataset " + data +
      " --backend cpu --particles 20000 --max_particles 20000 --init_candidates 200000 --max_beams 256"
      " --update_min_d 0 --update_min_a 0 --overwrite -o " +
      o;
  const CliResult r = run_cli(out, args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("from the first scan and the IMU"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(test::read_bytes(out / "run/report.json"));
  const auto& gravity = report["initialization"]["gravity"];
  EXPECT_EQ(gravity["source"], "imu");
  ASSERT_EQ(gravity["candidates"].size(), 1u);
  const Eigen::Vector3d up = truth[0].linear().transpose() * Eigen::Vector3d::UnitZ();
  const auto& c = gravity["candidates"][0]["up"];
  EXPECT_GT(up.dot(Eigen::Vector3d(c[0].get<double>(), c[1].get<double>(), c[2].get<double>())), std::cos(0.02));
  EXPECT_TRUE(report["summary"]["final_converged"].get<bool>());
  const CliResult e = run_cli(out, "evaluate --estimate " + o + "/trajectory.tum --dataset " + data);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto m = nlohmann::json::parse(e.out);
  EXPECT_TRUE(m["converged"].get<bool>()) << e.out;
  EXPECT_EQ(m["false_convergence"]["false_claims"].get<int>(), 0) << e.out;

  // A broken imu.txt is an error naming the line; --ignore_imu reads no IMU.
  std::ofstream(out / "office/imu.txt") << "0.0 0 0 9.81\n0.1 0 nine 9.81\n";
  test::expect_one_line_error(out, args, "imu.txt:2");
  const CliResult ignored = run_cli(out, args + " --ignore_imu --count 2");
  ASSERT_EQ(ignored.exit_code, 0) << ignored.err;
  EXPECT_EQ(ignored.err.find("and the IMU"), std::string::npos) << ignored.err;
}

TEST(CliLocalize, GlobalLocalizationWritesTrajectoryReportAndEvaluates) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string o = (out / "run").string();
  const CliResult r = run_cli(out, "localize --map " + f.map + " --dataset " + f.dataset + kGroundRobot + " -o " + o);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("localize: 24 scans, "), std::string::npos) << "the summary on stderr";

  // One TUM line per scan, stamped with times.txt to the nanosecond.
  std::istringstream tum(test::read_bytes(out / "run/trajectory.tum"));
  std::size_t lines = 0;
  for (std::string line; std::getline(tum, line); ++lines) {
    char expected[32];
    std::snprintf(expected, sizeof(expected), "%.9f ", kT0 + 0.5 * static_cast<double>(lines));
    EXPECT_EQ(line.rfind(expected, 0), 0u) << line;
  }
  EXPECT_EQ(lines, 24u);

  const auto report = nlohmann::json::parse(test::read_bytes(out / "run/report.json"));
  EXPECT_EQ(report["backend"], "cpu");
  EXPECT_EQ(report["parameters"]["max_beams"], 256);
  EXPECT_EQ(report["parameters"]["evidence_nats"], 3);
  EXPECT_EQ(report["scans"].size(), 24u);
  const auto& first = report["scans"][0];
  for (const char* key : {"motion", "upload", "weight", "walls", "own_points", "tempering", "places", "ledger",
                          "decision", "resample", "update_total"}) {
    EXPECT_TRUE(first["timings_ms"].contains(key)) << key;
  }
  EXPECT_EQ(first["particles"], 20000);
  EXPECT_TRUE(report["summary"]["final_converged"].get<bool>());
  EXPECT_LE(report["summary"]["particles"]["final"].get<int>(), 2000);
  // The state and the map coverage per scan and in the summary (docs/filter.md: where the map runs out).
  const auto& last = report["scans"].back();
  EXPECT_EQ(last["state"], "converged");
  EXPECT_GT(last["coverage"].get<double>(), 0.9);
  // Every update says how many points a concentrated cloud was weighed on among itself (null: all of them).
  for (const auto& scan : report["scans"]) {
    if (!scan["updated"].get<bool>()) continue;
    ASSERT_TRUE(scan["points"].contains("track_evidence"));
    const auto& weighed = scan["points"]["track_evidence"];
    if (!weighed.is_null()) {
      EXPECT_LE(weighed.get<int>(), scan["points"]["used"].get<int>());
    }
  }
  EXPECT_EQ(report["summary"]["final_state"], "converged");
  std::size_t by_state = 0;
  for (const auto& [name, count] : report["summary"]["scans_by_state"].items()) {
    EXPECT_TRUE(parse_track_state(name).has_value()) << name;
    by_state += count.get<std::size_t>();
  }
  EXPECT_EQ(by_state, 24u);
  EXPECT_NE(r.err.find("scans by state: "), std::string::npos) << r.err;

  const CliResult e = run_cli(
      out, "evaluate --estimate " + o + "/trajectory.tum --dataset " + f.dataset + " --plot " + o + "/errors.png");
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto metrics = nlohmann::json::parse(e.out);
  EXPECT_TRUE(metrics["converged"].get<bool>());
  EXPECT_LE(metrics["convergence"]["scan"].get<int>(), 8);
  EXPECT_LT(metrics["after_convergence"]["ate_rmse_m"].get<double>(), 0.1);
  EXPECT_LT(metrics["after_convergence"]["rotation_rmse_deg"].get<double>(), 2.0);
  EXPECT_EQ(test::read_bytes(out / "run/errors.png").substr(1, 3), "PNG");
}

// Parameters from a YAML or JSON file (nested keys join with '.'); flags win over the file.
TEST(CliLocalize, ConfigFileAndFlagPrecedence) {
  const Fixture& f = fixture();
  TempDir out;
  test::write_bytes(out / "params.yaml",
                    "max_beams: 128\nproof_travel: 3\ninit: initial_pose\n"
                    "initial_pose:\n  x: 2.0\n  y: 1.2\n  z: 0.9\n");
  const std::string common =
      "localize --map " + f.map + " --dataset " + f.dataset + " --backend cpu --count 3 --particles 500";
  CliResult r = run_cli(out, common + " --config " + (out / "params.yaml").string() + " -o " + (out / "a").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto report = nlohmann::json::parse(test::read_bytes(out / "a/report.json"));
  EXPECT_EQ(report["parameters"]["max_beams"], 128);
  EXPECT_EQ(report["parameters"]["proof_travel"], 3);
  EXPECT_EQ(report["initialization"]["mode"], "local");
  EXPECT_EQ(report["parameters"]["initial_pose.x"], 2.0);

  test::write_bytes(out / "params.json", R"({"max_beams": 128, "pf_z": 2.33})");
  r = run_cli(out,
              common + " --config " + (out / "params.json").string() + " --max_beams 64 -o " + (out / "b").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  report = nlohmann::json::parse(test::read_bytes(out / "b/report.json"));
  EXPECT_EQ(report["parameters"]["max_beams"], 64);
  EXPECT_EQ(report["parameters"]["pf_z"], 2.33);

  test::write_bytes(out / "bad.yaml", "max_beams: 128\npf_zz: 3\n");
  expect_one_line_error(out, common + " --config " + (out / "bad.yaml").string() + " -o " + (out / "c").string(),
                        "unknown parameter 'pf_zz'");
  test::write_bytes(out / "broken.yaml", "max_beams: [1, 2\n");
  expect_one_line_error(out, common + " --config " + (out / "broken.yaml").string() + " -o " + (out / "c").string(),
                        "not valid YAML");
}

TEST(CliLocalize, HelpListsEveryOptionWithItsDefault) {
  TempDir out;
  const CliResult r = run_cli(out, "localize --help");
  ASSERT_EQ(r.exit_code, 0);
  for (const char* s : {"--max_beams N", "[default: 512]", "--pf_z Z", "standard-normal quantile",
                        "--recovery_alpha_slow", "--alpha8", "--init_height_band", "--config FILE"}) {
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
  }
}

TEST(CliLocalize, BadInputGivesOneClearError) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string o = " --overwrite -o " + (out / "run").string();  // runs one after another into one folder
  const std::string base = "localize --map " + f.map + " --backend cpu --particles 200";

  // A dataset without odom.txt under the default odometry motion model.
  const std::filesystem::path no_odom = out / "no_odom";
  std::filesystem::copy(f.dataset, no_odom, std::filesystem::copy_options::recursive);
  std::filesystem::remove(no_odom / "odom.txt");
  expect_one_line_error(out, base + " --dataset " + no_odom.string() + o, "has no odom.txt");
  // ... which the constant-velocity model does not need.
  EXPECT_EQ(run_cli(out, base + " --dataset " + no_odom.string() + " --count 2 --motion_model constant_velocity" + o)
                .exit_code,
            0);

  // times.txt and poses.txt disagree.
  const std::filesystem::path mismatched = out / "mismatched";
  std::filesystem::copy(f.dataset, mismatched, std::filesystem::copy_options::recursive);
  std::string poses = test::read_bytes(mismatched / "poses.txt");
  poses.erase(poses.rfind('\n', poses.size() - 2) + 1);  // drop the last line
  test::write_bytes(mismatched / "poses.txt", poses);
  expect_one_line_error(out, base + " --dataset " + mismatched.string() + o, "lines in poses.txt");

  // An empty scan file.
  const std::filesystem::path empty = out / "empty";
  std::filesystem::copy(f.dataset, empty, std::filesystem::copy_options::recursive);
  test::write_bytes(empty / "scans/000002.bin", "");
  expect_one_line_error(out, base + " --dataset " + empty.string() + o, "000002.bin: empty scan file");

  // NaN points are dropped and counted; a scan of nothing but NaN is an error.
  const std::filesystem::path nan = out / "nan";
  std::filesystem::copy(f.dataset, nan, std::filesystem::copy_options::recursive);
  PointCloud scan = read_kitti_bin(nan / "scans/000001.bin");
  for (std::size_t k = 0; k < scan.size(); k += 10) scan.points[k].x() = std::nanf("");
  write_kitti_bin(nan / "scans/000001.bin", scan);
  const CliResult ok = run_cli(out, base + " --dataset " + nan.string() + " --count 3" + o);
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.err.find("dropped"), std::string::npos);
  const auto report = nlohmann::json::parse(test::read_bytes(out / "run/report.json"));
  EXPECT_EQ(report["summary"]["dropped_non_finite_points"].get<std::size_t>(), (scan.size() + 9) / 10);
  for (auto& p : scan.points) p.y() = std::nanf("");
  write_kitti_bin(nan / "scans/000001.bin", scan);
  expect_error_last(out, base + " --dataset " + nan.string() + " --count 3" + o, "000001.bin: no finite points");

  // Every point closer than laser_min_range.
  expect_error_last(out, base + " --dataset " + f.dataset + " --laser_min_range 50 --laser_max_range 60" + o,
                    "none of");

  // A map that is not a map, unknown options and values.
  test::write_bytes(out / "not_a_map.tsdf", "hello, I am a text file\n");
  expect_one_line_error(out, "localize --map " + (out / "not_a_map.tsdf").string() + " --dataset " + f.dataset + o,
                        "not_a_map.tsdf");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --max_beam 5" + o, "unknown option --max_beam");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --pf_err abc" + o, "pf_err expects a number");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --motion_model lucky" + o, "motion_model");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --init 1,2,3" + o, "init expects");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --converged_min_inliers 1.5" + o,
                        "converged_min_inliers must lie in [0, 1]");
  expect_one_line_error(out, base + " --dataset " + f.dataset + " --start 99" + o, "selects no scan");
  expect_one_line_error(out, base + " --dataset " + f.dataset, "missing -o");
}

// Hostile input (issue #10): counts that reached reserve() or the OpenMP runtime, configuration files that
// expand without bound or are not files, and a failed run into a folder holding a previous run's results.
TEST(CliLocalize, HostileCountsConfigsAndOutputFolders) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string base = "localize --map " + f.map + " --dataset " + f.dataset + " --backend cpu --particles 200";
  const std::string o = " --overwrite -o " + (out / "run").string();  // runs one after another into one folder
  expect_one_line_error(out, base + " --cpu_threads 100000" + o, "cpu_threads 100000 is more than the limit of 256");
  expect_one_line_error(out, base + " --particles 4294967296" + o, "particles 4294967296 is more than the limit");
  expect_one_line_error(out, base + " --max_particles 4294967295" + o, "max_particles 4294967295 is more than");
  expect_one_line_error(out, base + " --max_beams 4294967296" + o, "max_beams 4294967296 is more than");

  // A 1.4 KB alias bomb expanded to gigabytes; a folder given as --config was an "internal error".
  std::string bomb = "a: &a {k0: 1, k1: 1, k2: 1, k3: 1, k4: 1, k5: 1, k6: 1, k7: 1, k8: 1}\n";
  for (char c = 'b'; c <= 'j'; ++c) {
    bomb += std::string(1, c) + ": &" + c + " {";
    for (int k = 0; k < 9; ++k)
      bomb += std::string(k ? ", k" : "k") + std::to_string(k) + ": *" + static_cast<char>(c - 1);
    bomb += "}\n";
  }
  test::write_bytes(out / "bomb.yaml", bomb);
  expect_one_line_error(out, base + " --config " + (out / "bomb.yaml").string() + o, "YAML aliases expand");
  expect_one_line_error(out, base + " --config " + out.path().string() + o, "is a directory");

  // A failed run leaves the previous results untouched: no new snapshots beside an old report.
  const std::string good = base + " --count 3 --motion_model constant_velocity";
  ASSERT_EQ(run_cli(out, good + o).exit_code, 0);
  const std::string report = test::read_bytes(out / "run/report.json");
  const std::filesystem::path broken = out / "broken";
  std::filesystem::copy(f.dataset, broken, std::filesystem::copy_options::recursive);
  PointCloud nan_scan;
  nan_scan.points = {{std::nanf(""), 0, 0}};
  write_kitti_bin(broken / "scans/000002.bin", nan_scan);
  const CliResult failed = run_cli(out, "localize --map " + f.map + " --dataset " + broken.string() +
                                            " --backend cpu --particles 200 --count 3 --motion_model constant_velocity"
                                            " --snapshot_every 1" +
                                            o);
  EXPECT_NE(failed.exit_code, 0);
  EXPECT_EQ(test::read_bytes(out / "run/report.json"), report);
  EXPECT_FALSE(std::filesystem::exists(out / "run/snapshots"));
  // A successful run replaces every result of the previous one, and removes the staging folder a killed run left
  // (its process no longer exists: PIDs stop far below 2^31 - 1).
  const std::filesystem::path stale = out / ".run.partial-2147483647";
  std::filesystem::create_directories(stale / "snapshots");
  ASSERT_EQ(run_cli(out, good + " --snapshot_every 1" + o).exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_TRUE(std::filesystem::exists(out / "run/snapshots/scan_000002.bin"));
  ASSERT_EQ(run_cli(out, good + o).exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(out / "run/snapshots"));
  for (const auto& entry : std::filesystem::directory_iterator(out.path())) {
    EXPECT_EQ(entry.path().filename().string().find("partial"), std::string::npos) << entry.path();
  }
  // The output folder is checked before the map is loaded.
  test::write_bytes(out / "file", "x");
  expect_one_line_error(out, good + " -o " + (out / "file").string(), "is a file, not a folder");
}

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

// bench's output: one JSON object per line.
std::vector<nlohmann::json> json_lines(const std::string& out) {
  std::istringstream lines(out);
  std::string line;
  std::vector<nlohmann::json> rows;
  while (std::getline(lines, line)) rows.push_back(nlohmann::json::parse(line));
  return rows;
}

// bench: one JSON line per backend and particle count, with the fields docs/architecture.md names.
TEST(CliBench, PrintsOneJsonLinePerBackendAndCount) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string base = "bench --map " + f.map + " --dataset " + f.dataset +
                           " --scan 1 --particles 100,300 --points 64 --repetitions 1 --warmup 1";
  for (const std::string map_reads : {"texel", "storage"}) {
    const CliResult r = run_cli(out, base + " --backend reference,cpu,vulkan --map_reads " + map_reads);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::vector<nlohmann::json> rows = json_lines(r.out);
    ASSERT_EQ(rows.size(), 6u) << r.out;
    for (const auto& row : rows) {
      EXPECT_EQ(row["points"], 64);
      EXPECT_GT(row["median_ms"].get<double>(), 0.0);
      EXPECT_GT(row["evals_per_s"].get<double>(), 0.0);
      if (row["backend"] == "vulkan") {
        EXPECT_EQ(row["map_reads"], map_reads);
        EXPECT_EQ(row["weight_layout"], "invocation") << "lavapipe is a CPU device";
        EXPECT_FALSE(row["gpu_ms"].is_null()) << "lavapipe has timestamps";
      } else {
        EXPECT_TRUE(row["map_reads"].is_null());
      }
    }
    EXPECT_EQ(rows[0]["backend"], "reference");
    EXPECT_EQ(rows[1]["particles"], 300);
    EXPECT_EQ(rows[5]["backend"], "vulkan");
  }
}

// bench --weighing subset_first times the sensor update as the filter weighs large sets (the reference design
// always weighs the whole scan); --order spatial sorts the particles first. Each line says which it timed.
TEST(CliBench, SubsetFirstWeighingAndSpatialOrderAreNamedInTheirLines) {
  const Fixture& f = fixture();
  TempDir out;
  const CliResult r = run_cli(out, "bench --map " + f.map + " --dataset " + f.dataset +
                                       " --scan 1 --particles 1,500 --points 64 --repetitions 1 --warmup 1"
                                       " --backend reference,cpu,vulkan --weighing subset_first --subset_points 16"
                                       " --order spatial --spread global --weight_layout subgroup");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<nlohmann::json> rows = json_lines(r.out);
  ASSERT_EQ(rows.size(), 6u) << r.out;
  for (const auto& row : rows) {
    EXPECT_EQ(row["order"], "spatial");
    if (row["backend"] == "vulkan") {
      EXPECT_EQ(row["weight_layout"], "subgroup");
    }
    // One particle has no share to leave out: it is weighed whole, as are the reference design's.
    const bool subset = row["backend"] != "reference" && row["particles"] == 500;
    EXPECT_EQ(row["weighing"], subset ? "subset_first" : "whole") << row.dump();
    EXPECT_GT(row["median_ms"].get<double>(), 0.0);
  }
}

// A shader profiling run: per-pass GPU times and invocations, the shader-statistics line, and the dispatch loop
// for an external profiler, all as JSON lines that name their pass (validation on, as for every test).
TEST(CliBench, ProfileNamesEveryPass) {
  const Fixture& f = fixture();
  TempDir out;
  const CliResult r = run_cli(out, "bench --map " + f.map + " --dataset " + f.dataset +
                                       " --scan 1 --particles 100,300 --points 64 --repetitions 2 --warmup 1"
                                       " --backend cpu,vulkan --profile --loop 0.3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::map<std::string, std::vector<nlohmann::json>> by_kind;
  for (const nlohmann::json& row : json_lines(r.out)) {
    by_kind[row.contains("profile") ? row["profile"].get<std::string>() : "measurement"].push_back(row);
  }
  EXPECT_EQ(by_kind["measurement"].size(), 4u);
  ASSERT_EQ(by_kind["pass"].size(), 6u) << "transfer, weight, reduce for each Vulkan count; none for the CPU";
  for (std::size_t i = 0; i < 6; ++i) {
    const nlohmann::json& pass = by_kind["pass"][i];
    EXPECT_EQ(pass["backend"], "vulkan");
    EXPECT_EQ(pass["pass"], std::vector<std::string>({"transfer", "weight", "reduce"})[i % 3]);
    EXPECT_FALSE(pass["gpu_ms"].is_null()) << "lavapipe has timestamps";
    if (pass["pass"] == "weight") {
      ASSERT_FALSE(pass["invocations"].is_null()) << "lavapipe has pipeline statistics";
      EXPECT_GE(pass["invocations"].get<std::uint64_t>(), pass["particles"].get<std::uint64_t>());
    }
  }
  ASSERT_EQ(by_kind["shader"].size(), 1u) << "lavapipe reports no shader statistics: one line that says so";
  EXPECT_TRUE(by_kind["shader"][0]["statistics"].is_null());
  ASSERT_EQ(by_kind["loop"].size(), 2u) << "one dispatch loop per backend";
  for (const auto& loop : by_kind["loop"]) {
    EXPECT_EQ(loop["particles"], 300);
    EXPECT_GE(loop["updates"].get<std::size_t>(), 1u);
    EXPECT_GE(loop["seconds"].get<double>(), 0.3);
  }
}

TEST(CliBench, BadInputGivesOneClearError) {
  const Fixture& f = fixture();
  TempDir out;
  const std::string base = "bench --map " + f.map + " --dataset " + f.dataset + " --particles 10 --points 8";
  expect_one_line_error(out, base + " --backend cuda", "unknown backend 'cuda'");
  expect_one_line_error(out, base + " --map_reads fast", "--map_reads must be texel or storage");
  expect_one_line_error(out, base + " --likelihood max", "--likelihood must be product or sum");
  expect_one_line_error(out, base + " --interpolation cubic", "--interpolation must be nearest or trilinear");
  expect_one_line_error(out, base + " --spread far", "--spread must be local or global");
  expect_one_line_error(out, base + " --particles 0", "--particles needs positive integers");
  expect_one_line_error(out, base + " --points 0", "--points must be positive");
  expect_one_line_error(out, base + " --loop -1", "--loop must lie in [0, 86400] s");
  expect_one_line_error(out, base + " --weighing half", "--weighing must be whole or subset_first");
  expect_one_line_error(out, base + " --weight_layout warp", "unknown weight_layout 'warp'");
  expect_one_line_error(out, base + " --order random", "--order must be spatial or none");
  expect_one_line_error(out, base + " --subset_share 0", "subset_share must lie in (0, 1]");
  expect_one_line_error(out, base + " --scan 999", "--scan 999 but the dataset has 24 scans");
  expect_one_line_error(out, "bench --map " + (out / "missing.tsdf").string() + " --dataset " + f.dataset,
                        "missing.tsdf");
  expect_one_line_error(out, "bench --map " + f.map + " --dataset " + (out / "nowhere").string(), "nowhere");
}

}  // namespace
}  // namespace tsdf_mcl
