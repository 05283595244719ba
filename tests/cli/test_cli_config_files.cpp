// localize --config is strict (issue 52): a value of the wrong kind is refused even where the command line gives the
// parameter too, a one-element list is not a number, a second YAML document is not dropped unread, and a .json file
// is JSON.
#include <gtest/gtest.h>

#include <string>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"

namespace tsdf_mcl {
namespace {

using test::expect_one_line_error;
using test::fixture;
using test::run_cli;
using test::TempDir;

TEST(CliConfigFiles, FilesAreStrictWhateverTheCommandLineGives) {
  TempDir out;
  const std::string common = "localize --map " + fixture().map + " --dataset " + fixture().dataset +
                             " --backend cpu --count 2 --particles 300 -o " + (out / "run").string();
  const auto config = [&](const std::string& name, const std::string& text) {
    test::write_bytes(out / name, text);
    return common + " --config " + (out / name).string();
  };
  expect_one_line_error(out, config("many.json", R"({"particles": "many"})"),
                        "many.json: particles expects an integer, got 'many'");
  expect_one_line_error(out, config("flag.json", R"({"particles": true})") + " --particles 100",
                        "flag.json: particles expects an integer, got 'true'");
  expect_one_line_error(out, config("many.yaml", "particles: many\n") + " --particles 100",
                        "many.yaml: particles expects an integer");
  expect_one_line_error(out, config("list.json", R"({"sigma_hit": [1]})"), "list.json: sigma_hit: a list of 1 items");
  expect_one_line_error(out, config("two.yaml", "max_beams: 64\n---\nmax_beams: 32\n"),
                        "two.yaml: holds more than one YAML document");
  expect_one_line_error(out, config("comma.json", R"({"max_beams": 64,})"), "comma.json: not valid JSON");
  expect_one_line_error(out, config("band.yaml", "init_height_band: [0, 1e300]\n"),
                        "init_height_band 1e+300 m lies beyond the map's height");
  EXPECT_FALSE(std::filesystem::exists(out / "run"));
  // The same values in their right forms run.
  const test::CliResult r = run_cli(out, config("good.yaml", "max_beams: 64\ninit_height_band: [0.5, 1.5]\n"));
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace tsdf_mcl
