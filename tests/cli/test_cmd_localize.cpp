// The localize command end to end on a small synthetic dataset, and its answers to bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
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
  // Each stage is part of the update: none outlasts it, and together they do not either.
  const double total = first["timings_ms"]["update_total"].get<double>();
  EXPECT_GT(total, 0.0);
  double stages = 0.0;
  for (const char* key :
       {"motion", "upload", "weight", "walls", "own_points", "tempering", "places", "ledger", "decision", "resample"}) {
    ASSERT_TRUE(first["timings_ms"].contains(key)) << key;
    EXPECT_LE(first["timings_ms"][key].get<double>(), total) << key;
    stages += first["timings_ms"][key].get<double>();
  }
  EXPECT_LE(stages, total * 1.001 + 1e-3);
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
                        "--recovery_alpha_slow", "--alpha5", "--init_height_band", "--config FILE"}) {
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
  }
  // The expert options only with --help-all.
  EXPECT_EQ(r.out.find("--alpha8"), std::string::npos);
  const CliResult all = run_cli(out, "localize --help-all");
  ASSERT_EQ(all.exit_code, 0);
  EXPECT_NE(all.out.find("expert options:"), std::string::npos);
  EXPECT_NE(all.out.find("--alpha8"), std::string::npos);
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

}  // namespace
}  // namespace tsdf_mcl
