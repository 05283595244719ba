// What a person sees (issue 17): progress lines in a pipe, --quiet and --verbose, the two words "converged" (the
// filter's flag) and "localized" (evaluate's ground-truth test), the explanation of a wrong initial pose, angle
// units, --version, "did you mean" and --help within 100 columns.
#include <gtest/gtest.h>

#include <cstdlib>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::fixture;
using test::run_cli;
using test::TempDir;

const std::string kGroundRobot =
    " --backend cpu --particles 20000 --max_particles 20000 --min_particles 300 --init_max_tilt 0.1"
    " --init_height_band 0.6,1.2 --max_beams 256 --update_min_d 0 --update_min_a 0";

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::size_t count_containing(const std::vector<std::string>& lines, const std::string& words) {
  return static_cast<std::size_t>(std::count_if(
      lines.begin(), lines.end(), [&](const std::string& l) { return l.find(words) != std::string::npos; }));
}

std::string localize(const std::string& extra, const TempDir& out, const std::string& run) {
  return "localize --map " + fixture().map + " --dataset " + fixture().dataset + kGroundRobot + extra + " -o " +
         (out / run).string();
}

// stderr is a file here, as in a pipe or a log: no per-scan lines, no terminal control characters, a line at
// each state change and every few seconds (every update with the interval at 0), the summary last.
TEST(CliUx, ProgressInAPipeQuietAndVerbose) {
  TempDir out;
  CliResult r = run_cli(out, localize("", out, "a"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> lines = lines_of(r.err);
  EXPECT_LE(lines.size(), 8u) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos);
  EXPECT_EQ(count_containing(lines, "[1/24]"), 0u) << r.err;
  EXPECT_EQ(count_containing(lines, ": converged ("), 1u) << "the state change to converged: " << r.err;
  EXPECT_EQ(lines.back().rfind("localize: 24 scans, ", 0), 0u) << r.err;
  EXPECT_NE(lines.back().find("converged (the filter's own flag) since scan"), std::string::npos) << r.err;

  setenv("TSDF_MCL_PROGRESS_INTERVAL", "0", 1);
  r = run_cli(out, localize("", out, "b"));
  unsetenv("TSDF_MCL_PROGRESS_INTERVAL");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  lines = lines_of(r.err);
  EXPECT_GE(count_containing(lines, "/24 scans, "), 23u) << r.err;
  EXPECT_NE(r.err.find("scans/s, ETA"), std::string::npos) << r.err;

  r = run_cli(out, localize(" --quiet", out, "c"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  lines = lines_of(r.err);
  ASSERT_EQ(lines.size(), 1u) << r.err;
  EXPECT_EQ(lines[0].rfind("localize: 24 scans, ", 0), 0u) << r.err;

  r = run_cli(out, localize(" --verbose", out, "d"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(count_containing(lines_of(r.err), "] scan "), 24u) << r.err;
  EXPECT_NE(r.err.find("[24/24] scan 23"), std::string::npos) << r.err;
  expect_one_line_error(out, localize(" --quiet --verbose", out, "e"), "--quiet and --verbose contradict");
}

// A wrong initial pose far from the truth (the run starts at 2, 1.2, upright; this one lies on its side),
// recovery off, 2 scans (a claim takes converged_min_updates, 3, at one place; the background search may find the
// true place from the first update): localize says the scan does not fit there and that the filter never claimed
// convergence; evaluate keeps its ground-truth test apart from the filter's flag.
TEST(CliUx, ARunThatNeverConvergesSaysSoInBothWords) {
  TempDir out;
  const std::string run = (out / "wrong").string();
  const CliResult r = run_cli(out, "localize --map " + fixture().map + " --dataset " + fixture().dataset +
                                       " --backend cpu --particles 500 --max_particles 500 --count 2 "
                                       "--recovery_alpha_slow 0 --recovery_alpha_fast 0 --recovery_min_inliers 0 "
                                       "--init 12.5,8,0.9,90deg,0,180deg -o " +
                                       run);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("does not fit at the given initial pose"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the filter is searching"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("NOT converged: the filter never claimed convergence"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(test::read_bytes(out / "wrong/report.json"));
  EXPECT_TRUE(report["summary"]["first_converged_scan"].is_null());

  const CliResult e = run_cli(out, "evaluate --estimate " + run + "/trajectory.tum --dataset " + fixture().dataset);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_NE(e.err.find("the filter never claimed convergence"), std::string::npos) << e.err;
  EXPECT_EQ(e.err.find("no false convergence"), std::string::npos) << "reads like a pass: " << e.err;
  const auto metrics = nlohmann::json::parse(e.out);
  // Its background search finds the true place (localized), yet the filter never says converged: two words.
  EXPECT_NE(e.err.find(metrics["localized"].get<bool>() ? "localized from scan" : "NOT localized"), std::string::npos);
  EXPECT_EQ(metrics["filter_converged"]["claimed_scans"], 0);
  EXPECT_TRUE(metrics["filter_converged"]["first_scan"].is_null());
}

TEST(CliUx, AConvergingRunIsLocalizedFromAScanAndFlaggedConverged) {
  TempDir out;
  const std::string run = (out / "run").string();
  ASSERT_EQ(run_cli(out, localize("", out, "run")).exit_code, 0);
  const CliResult e = run_cli(out, "evaluate --estimate " + run + "/trajectory.tum --dataset " + fixture().dataset +
                                       " --max_rotation_error 0.1rad");
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_NE(e.err.find("localized from scan "), std::string::npos) << e.err;
  EXPECT_NE(e.err.find("the filter flagged converged at "), std::string::npos) << e.err;
  const auto metrics = nlohmann::json::parse(e.out);
  EXPECT_TRUE(metrics["localized"].get<bool>());
  EXPECT_EQ(metrics["localized_from"]["scan"], metrics["convergence"]["scan"]);
  EXPECT_GT(metrics["filter_converged"]["claimed_scans"].get<int>(), 0);
  EXPECT_NEAR(metrics["thresholds"]["rotation_deg"].get<double>(), 5.7296, 1e-3);
}

// Degrees where radians are expected are rejected with the way to say degrees; units are accepted everywhere.
TEST(CliUx, ImplausibleAnglesAreRejectedWithAHint) {
  TempDir out;
  expect_one_line_error(out, localize(" --init 2,1,0.9,0,0,90", out, "a"), "for degrees write 90deg");
  expect_one_line_error(out, localize(" --update_min_a 30", out, "a"), "update_min_a 30 is more than");
  expect_one_line_error(out, localize(" --init_sigma_yaw 1e3deg", out, "a"), "is more than");
  expect_one_line_error(out, "simulate --route test --start 1,2,1000 -o " + (out / "s").string(),
                        "--start's yaw 1000deg is more than");
  expect_one_line_error(out, "evaluate --estimate x.tum --dataset " + fixture().dataset + " --max_rotation_error 5rad",
                        "--max_rotation_error 5rad is more than");
  const CliResult help = run_cli(out, "localize --help");
  EXPECT_NE(help.out.find("Angles are in radians as in nav2"), std::string::npos);
  EXPECT_NE(help.out.find("90deg"), std::string::npos);
}

TEST(CliUx, VersionInTheProgramAndTheReport) {
  TempDir out;
  const CliResult v = run_cli(out, "--version");
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_EQ(v.out, std::string("tsdf-mcl ") + TSDF_MCL_VERSION + "\n");
  ASSERT_EQ(run_cli(out, localize(" --count 2 --quiet", out, "run")).exit_code, 0);
  const auto report = nlohmann::json::parse(test::read_bytes(out / "run/report.json"));
  EXPECT_EQ(report["version"], TSDF_MCL_VERSION);
}

// A second run into the same folder keeps the first one's results unless --overwrite says to replace them.
TEST(CliUx, AnEarlierRunIsKeptUnlessOverwriteIsGiven) {
  TempDir out;
  ASSERT_EQ(run_cli(out, localize(" --count 2 --quiet", out, "run")).exit_code, 0);
  const std::string first = test::read_bytes(out / "run/trajectory.tum");
  expect_one_line_error(out, localize(" --count 3 --quiet", out, "run"),
                        "holds an earlier run's results (report.json); pass --overwrite");
  EXPECT_EQ(test::read_bytes(out / "run/trajectory.tum"), first) << "a refused run must not touch the folder";
  ASSERT_EQ(run_cli(out, localize(" --count 3 --quiet --overwrite", out, "run")).exit_code, 0);
  EXPECT_NE(test::read_bytes(out / "run/trajectory.tum"), first);
}

TEST(CliUx, DidYouMeanForCommandsOptionsAndParameters) {
  TempDir out;
  CliResult r = run_cli(out, "locailze --map x");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(lines_of(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find("unknown command 'locailze' (did you mean tsdf-mcl localize?)"), std::string::npos) << r.err;
  r = run_cli(out, "frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown command 'frobnicate'; tsdf-mcl --help lists the commands"), std::string::npos);
  expect_one_line_error(out, localize(" --partcles 5", out, "a"),
                        "unknown option --partcles (did you mean --particles?)");
  expect_one_line_error(out, "build-map --voxle 0.1 -o m.tsdf", "(did you mean --voxel?)");
  test::write_bytes(out / "typo.yaml", "sigma_hitt: 0.2\n");
  expect_one_line_error(out, localize(" --config " + (out / "typo.yaml").string(), out, "a"),
                        "typo.yaml: unknown parameter 'sigma_hitt' (did you mean sigma_hit?)");
}

// Issue 21: config values a parser accepted silently are one error naming the file and the field.
TEST(CliUx, ConfigFilesNameTheFileAndTheField) {
  TempDir out;
  const auto config_error = [&](const std::string& name, const std::string& text, const std::string& words) {
    test::write_bytes(out / name, text);
    expect_one_line_error(out, localize(" --config " + (out / name).string(), out, "a"), name + ": " + words);
  };
  config_error("types.json", R"({"ignore_imu": 3})", "ignore_imu expects true or false, got '3'");
  config_error("list.json", R"({"resample_interval": [1, 2]})", "resample_interval expects an integer, got '1,2'");
  config_error("big.json", R"({"max_particles": 18446744073709551616})", "max_particles: the number");
  config_error("nul.yaml", "sigma_hit: \"0.1\\0junk\"\n", "sigma_hit: the value holds a control character (NUL)");
  std::string utf16 = "\xFF\xFE";
  for (const char c : std::string("sigma_hit: 0.2\n")) utf16 += std::string(1, c) + '\0';
  config_error("utf16.yaml", utf16, "UTF-16");
  config_error("alias.yaml", "kld_z: 2\npf_z: 3\n", "kld_z is amcl's name of pf_z");
}

// Every --help fits a 100-column terminal; localize's is grouped, the essentials first.
TEST(CliUx, HelpFitsOneHundredColumnsAndLocalizeIsGrouped) {
  TempDir out;
  for (const char* command :
       {"", "build-map", "info", "simulate", "localize", "evaluate", "bench", "render", "export-cloud"}) {
    const CliResult r = run_cli(out, std::string(command) + " --help");
    ASSERT_EQ(r.exit_code, 0) << command;
    for (const std::string& line : lines_of(r.out)) EXPECT_LE(line.size(), 100u) << command << ": " << line;
  }
  const std::string help = run_cli(out, "localize --help").out;
  std::size_t last = 0;
  for (const char* group : {"input options:", "initialization options:", "output options:", "filter options:",
                            "sensor model options:", "decision options:", "runtime options:"}) {
    const std::size_t at = help.find(std::string("\n") + group + "\n");
    ASSERT_NE(at, std::string::npos) << group;
    EXPECT_GT(at, last) << group;
    last = at;
  }
  EXPECT_LT(help.find("--particles N"), help.find("--pf_z Z"));
  EXPECT_LT(help.find("--pf_z Z"), help.find("--sigma_hit M"));
  const std::string main_help = run_cli(out, "--help").out;
  EXPECT_NE(main_help.find("  export-cloud  write"), std::string::npos) << main_help;
  EXPECT_NE(main_help.find("  info          print"), std::string::npos) << main_help;
}

}  // namespace
}  // namespace tsdf_mcl
