// The bench command on the office fixture's map and dataset: its JSON lines, and its answers to bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
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
using test::Fixture;
using test::run_cli;
using test::TempDir;

// bench's output: one JSON object per line.
std::vector<nlohmann::json> json_lines(const std::string& out) {
  std::istringstream lines(out);
  std::string line;
  std::vector<nlohmann::json> rows;
  while (std::getline(lines, line)) rows.push_back(nlohmann::json::parse(line));
  return rows;
}

// A measurement's timings agree with each other: the rate is particles x points over the median (docs/architecture.md),
// the fastest repetition is no slower than the median, the GPU's share no longer than the whole update.
void expect_consistent_timings(const nlohmann::json& row) {
  const double median = row["median_ms"].get<double>();
  ASSERT_GT(median, 0.0) << row.dump();
  const double evals = row["particles"].get<double>() * row["points"].get<double>();
  EXPECT_NEAR(row["evals_per_s"].get<double>(), evals / (median * 1e-3), 1e-9 * evals / (median * 1e-3)) << row.dump();
  EXPECT_LE(row["min_ms"].get<double>(), median) << row.dump();
  EXPECT_GT(row["min_ms"].get<double>(), 0.0) << row.dump();
  if (!row["gpu_ms"].is_null()) {
    EXPECT_LE(row["gpu_ms"].get<double>(), median) << row.dump();
  }
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
      expect_consistent_timings(row);
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
    expect_consistent_timings(row);
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
    // The mean is the loop's time over its updates (the loop runs until --loop has passed, so that bound holds
    // by construction and says nothing).
    const double seconds = loop["seconds"].get<double>();
    EXPECT_NEAR(loop["mean_ms"].get<double>(), 1e3 * seconds / loop["updates"].get<double>(), 1e-9 * (1.0 + seconds));
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

// bench is the benchmark program beside tsdf-mcl (bench/), run in the program's place: the same help; a tsdf-mcl
// without it says so in one line.
TEST(CliBench, RunsTheBenchmarkProgramBesideIt) {
  TempDir out;
  const CliResult help = run_cli(out, "bench --help");
  ASSERT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find("tsdf-mcl bench --map MAP --dataset DIR"), std::string::npos) << help.out;
  const std::filesystem::path bench = std::filesystem::path(test::cli_program()).parent_path() / "tsdf-mcl-bench";
  const int direct = std::system(("'" + bench.string() + "' --help >'" + (out / "help.txt").string() + "'").c_str());
  ASSERT_TRUE(WIFEXITED(direct) && WEXITSTATUS(direct) == 0);
  EXPECT_EQ(test::read_bytes(out / "help.txt"), help.out);

  std::filesystem::copy_file(test::cli_program(), out / "tsdf-mcl");
  const int alone = std::system(
      ("'" + (out / "tsdf-mcl").string() + "' bench --help 2>'" + (out / "err.txt").string() + "'").c_str());
  EXPECT_TRUE(WIFEXITED(alone) && WEXITSTATUS(alone) == 1);
  const std::string err = test::read_bytes(out / "err.txt");
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("tsdf-mcl bench: error: cannot run the benchmark program " + (out / "tsdf-mcl-bench").string() +
                     ": No such file or directory"),
            std::string::npos)
      << err;
}

}  // namespace
}  // namespace tsdf_mcl
