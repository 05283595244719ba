// The library's parameter schema (localizer_parameters.hpp) and parameter files (parameter_file.hpp): the one
// table the command line, config files, the ROS node and the Python bindings adapt.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "checkout_paths.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"

namespace tsdf_mcl {
namespace {

using test::TempDir;

// The Error's message for `values`, or "" when they are accepted.
std::string error_of(const std::map<std::string, std::string>& values) {
  try {
    localizer_options_from(values);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string file_error(const TempDir& dir, const std::string& name, const std::string& bytes) {
  test::write_bytes(dir / name, bytes);
  try {
    const auto values = read_parameter_file((dir / name).string());
    localizer_options_from(values);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

double yaw_of(const Pose& p) { return std::atan2(p.rotation()(1, 0), p.rotation()(0, 0)); }

TEST(LocalizerParameters, EveryNameOnceInAKnownGroupAndTheDefaultsAreTheLibrarys) {
  std::set<std::string> names;
  const std::set<std::string> groups = {"initialization", "filter", "sensor model", "decision", "runtime", "expert"};
  std::size_t shown = 0;
  for (const ParameterSpec& s : localizer_parameter_specs()) {
    EXPECT_TRUE(names.insert(s.name).second) << s.name;
    EXPECT_TRUE(groups.count(s.group)) << s.name << " in group '" << s.group << "'";
    EXPECT_FALSE(s.help.empty()) << s.name;
    shown += s.group != "expert" ? 1 : 0;
  }
  // A user meets few parameters: at most 40 in localize --help, 50 in all (--help-all).
  EXPECT_LE(shown, 40u);
  EXPECT_LE(names.size(), 50u);
  for (const ParameterAlias& a : localizer_parameter_aliases()) {
    EXPECT_TRUE(names.count(a.name)) << a.alias << " -> " << a.name;
    EXPECT_FALSE(names.count(a.alias)) << a.alias;
  }
  const LocalizerOptions o = localizer_options_from({});
  const FilterParameters f;
  EXPECT_EQ(o.filter.initial_particles, f.initial_particles);
  EXPECT_EQ(o.filter.kld.max_particles, f.kld.max_particles);
  EXPECT_FLOAT_EQ(o.filter.sensor.sigma_hit, f.sensor.sigma_hit);
  EXPECT_DOUBLE_EQ(o.filter.update_min_a, f.update_min_a);
  EXPECT_DOUBLE_EQ(o.filter.ledger.decide_nats, f.ledger.decide_nats);
  EXPECT_DOUBLE_EQ(o.filter.ledger.window_m, f.ledger.window_m);
  EXPECT_DOUBLE_EQ(o.filter.states.min_inliers, f.states.min_inliers);
  EXPECT_DOUBLE_EQ(o.filter.motion.diffusion_z, f.motion.diffusion_z);
  EXPECT_DOUBLE_EQ(o.filter.motion.diffusion_roll_pitch, f.motion.diffusion_roll_pitch);
  EXPECT_NEAR(o.filter.local_init.sigma_roll_pitch, f.local_init.sigma_roll_pitch, 1e-6);  // the help's digits
  EXPECT_EQ(o.preprocessing.max_beams, ScanPreprocessing{}.max_beams);
  EXPECT_FALSE(o.initial_pose.has_value());
  EXPECT_TRUE(o.use_imu);
}

// docs/parameters.md is the table's: regenerate it with `tsdf-mcl localize --help-markdown > docs/parameters.md`.
TEST(LocalizerParameters, TheReferenceDocIsGeneratedFromTheTable) {
  const std::filesystem::path doc =
      std::filesystem::path(test::test_data_dir()).parent_path().parent_path() / "docs" / "parameters.md";
  std::ifstream in(doc);
  ASSERT_TRUE(in) << doc;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, parameters_markdown()) << doc << " differs from the table: run tsdf-mcl localize --help-markdown";
  for (const ParameterSpec& s : localizer_parameter_specs()) {
    EXPECT_NE(text.find("| `" + s.name + "` |"), std::string::npos) << s.name;
  }
}

TEST(LocalizerParameters, ValuesSetTheirFieldsAndAnglesTakeUnits) {
  const LocalizerOptions o = localizer_options_from({{"particles", "777"},
                                                     {"sigma_hit", "0.25"},
                                                     {"ignore_imu", "true"},
                                                     {"imu_rotation_sigma", "0.01"},
                                                     {"update_min_a", "10deg"},
                                                     {"evidence_nats", "4"},
                                                     {"proof_travel", "3"},
                                                     {"converged_min_inliers", "0.6"},
                                                     {"diffusion_xy", "0.4"},
                                                     {"init", "initial_pose"},
                                                     {"initial_pose.x", "2"},
                                                     {"initial_pose.yaw", "90deg"}});
  EXPECT_EQ(o.filter.initial_particles, 777u);
  EXPECT_FLOAT_EQ(o.filter.sensor.sigma_hit, 0.25f);
  EXPECT_FALSE(o.use_imu);
  EXPECT_TRUE(o.filter.motion.imu_rotation);
  EXPECT_DOUBLE_EQ(o.filter.motion.imu_sigma, 0.01);
  EXPECT_NEAR(o.filter.update_min_a, 10.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(o.filter.ledger.decide_nats, 4.0);
  EXPECT_EQ(o.filter.ledger.window_m, 3.0);
  EXPECT_EQ(o.filter.states.min_inliers, 0.6);
  EXPECT_DOUBLE_EQ(o.filter.motion.diffusion_z, 0.1) << "a quarter of diffusion_xy";
  ASSERT_TRUE(o.initial_pose.has_value());
  EXPECT_NEAR(o.initial_pose->translation().x(), 2.0, 1e-12);
  EXPECT_NEAR(yaw_of(*o.initial_pose), M_PI / 2, 1e-9);

  const LocalizerOptions inline_pose = localizer_options_from({{"init", "1,2,0.5,0,0,1.5rad"}});
  ASSERT_TRUE(inline_pose.initial_pose.has_value());
  EXPECT_NEAR(yaw_of(*inline_pose.initial_pose), 1.5, 1e-9);
}

TEST(LocalizerParameters, AmclNamesAreAliases) {
  const LocalizerOptions o = localizer_options_from(
      {{"kld_z", "2.33"}, {"laser_max_beams", "64"}, {"odom_alpha1", "0.5"}, {"odom_model_type", "diff-corrected"}});
  EXPECT_DOUBLE_EQ(o.filter.kld.pf_z, 2.33);
  EXPECT_EQ(o.preprocessing.max_beams, 64u);
  EXPECT_DOUBLE_EQ(o.filter.motion.alpha1, 0.5);
  EXPECT_EQ(o.filter.motion.type, MotionModelType::kOdometry);
  EXPECT_NE(error_of({{"kld_z", "2"}, {"pf_z", "3"}}).find("kld_z is amcl's name of pf_z"), std::string::npos);
  EXPECT_NE(error_of({{"odom_model_type", "tank"}}).find("odom_model_type must be"), std::string::npos);
}

TEST(LocalizerParameters, BadValuesNameTheirParameter) {
  EXPECT_EQ(error_of({{"pf_zz", "3"}}), "unknown parameter 'pf_zz' (did you mean pf_z?)");
  EXPECT_NE(error_of({{"max_beam", "3"}}).find("did you mean max_beams"), std::string::npos);
  EXPECT_EQ(error_of({{"completely_unrelated_name", "3"}}), "unknown parameter 'completely_unrelated_name'");
  EXPECT_NE(error_of({{"pf_err", "abc"}}).find("pf_err expects a number, got 'abc'"), std::string::npos);
  EXPECT_NE(error_of({{"sigma_hit", std::string("0.1\0junk", 8)}}).find("sigma_hit: the value holds a NUL"),
            std::string::npos);
  EXPECT_NE(error_of({{"max_beams", "1e3"}}).find("max_beams expects an integer"), std::string::npos);
  EXPECT_NE(error_of({{"max_particles", "4294967296"}}).find("max_particles 4294967296 is more than the limit"),
            std::string::npos);
  EXPECT_NE(error_of({{"motion_model", "max"}}).find("motion_model"), std::string::npos);
  EXPECT_NE(error_of({{"ignore_imu", "3"}}).find("ignore_imu expects true or false"), std::string::npos);
  EXPECT_NE(error_of({{"init", "1,2,3"}}).find("init expects global, initial_pose or x,y,z,roll,pitch,yaw"),
            std::string::npos);
}

// Degrees given where radians are expected: beyond a full turn, rejected with the way to say degrees.
TEST(LocalizerParameters, ImplausibleRadiansAreRejectedWithAHint) {
  EXPECT_NE(error_of({{"init", "1,2,0,0,0,90"}}).find("init's yaw 90 is more than 6.28319 rad"), std::string::npos);
  EXPECT_NE(error_of({{"init", "1,2,0,0,0,90"}}).find("write 90deg"), std::string::npos);
  EXPECT_NE(error_of({{"initial_pose.yaw", "180"}}).find("initial_pose.yaw 180 is more than"), std::string::npos);
  EXPECT_NE(error_of({{"update_min_a", "720deg"}}).find("(360 deg)"), std::string::npos);
  EXPECT_NE(error_of({{"update_min_a", "fastdeg"}}).find("expects an angle"), std::string::npos);
  EXPECT_EQ(error_of({{"init", "1,2,0,0,0,-3.1"}}), "");
}

TEST(LocalizerParameters, ClosestNamesForDidYouMean) {
  const std::vector<std::string> known = {"localize", "build-map", "render", "evaluate", "info"};
  EXPECT_EQ(closest_names("locailze", known), std::vector<std::string>{"localize"});
  EXPECT_EQ(closest_names("buildmap", known), std::vector<std::string>{"build-map"});
  EXPECT_TRUE(closest_names("xyzzy", known).empty());
  EXPECT_EQ(did_you_mean("rendr", known, "tsdf-mcl "), " (did you mean tsdf-mcl render?)");
}

// Issue 21: config files a parser accepted silently; each is now one error naming the file and the field.
TEST(ParameterFile, HostileFilesAreOneErrorNamingFileAndField) {
  TempDir dir;
  std::string utf16 = "\xFF\xFE";
  for (const char c : std::string("sigma_hit: 0.2\n")) utf16 += std::string(1, c) + '\0';
  std::string e = file_error(dir, "utf16.yaml", utf16);
  EXPECT_NE(e.find("utf16.yaml: UTF-16"), std::string::npos) << e;
  e = file_error(dir, "utf16_nobom.yaml", utf16.substr(2));
  EXPECT_NE(e.find("utf16_nobom.yaml: NUL byte at offset 1"), std::string::npos) << e;
  e = file_error(dir, "nul.yaml", "sigma_hit: \"0.1\\0junk\"\n");
  EXPECT_NE(e.find("nul.yaml: sigma_hit: the value holds a control character (NUL)"), std::string::npos) << e;
  e = file_error(dir, "range.json", R"({"max_beams": 99999999999999999999999})");
  EXPECT_NE(e.find("range.json: max_beams: the number 99999999999999999999999 is out of range"), std::string::npos)
      << e;
  e = file_error(dir, "huge.json", R"({"sigma_hit": 1e999})");
  EXPECT_NE(e.find("huge.json: sigma_hit: the number 1e999 is out of range"), std::string::npos) << e;
  e = file_error(dir, "twice.yaml", "pf_z: 1\npf_z: 2\n");
  EXPECT_NE(e.find("twice.yaml: pf_z is given twice"), std::string::npos) << e;
  e = file_error(dir, "nested.json", R"({"initial_pose": {"x": 1, "y": 2}, "alpha1": 0.1})");
  EXPECT_EQ(e, "");
  EXPECT_EQ(read_parameter_file((dir / "nested.json").string()).at("initial_pose.y"), "2");
}

// A parameter file is one YAML document, a .json file is JSON, and a list is the value of a parameter that takes
// several: the forms yaml-cpp would otherwise read into something else.
TEST(ParameterFile, StrictFormsAreOneErrorNamingTheFile) {
  TempDir dir;
  std::string e = file_error(dir, "two.yaml", "particles: 100\n---\nparticles: 5\n");
  EXPECT_NE(e.find("two.yaml: holds more than one YAML document"), std::string::npos) << e;
  // yaml-cpp's LoadAll reads this as endless empty documents (the config fuzzer's timeout): an error, at once.
  e = file_error(dir, "endless.yaml", ",:red");
  EXPECT_NE(e.find("endless.yaml: "), std::string::npos) << e;
  e = file_error(dir, "comma.json", R"({"particles": 100,})");
  EXPECT_NE(e.find("comma.json: not valid JSON"), std::string::npos) << e;
  EXPECT_EQ(file_error(dir, "comma.yaml", "{particles: 100,}"), "") << "YAML's flow style allows it";
  e = file_error(dir, "one.json", R"({"sigma_hit": [1]})");
  EXPECT_NE(e.find("one.json: sigma_hit: a list of 1 items"), std::string::npos) << e;
  e = file_error(dir, "none.yaml", "ignore_imu: []\n");
  EXPECT_NE(e.find("none.yaml: ignore_imu: a list of 0 items"), std::string::npos) << e;
  EXPECT_EQ(file_error(dir, "band.json", R"({"init_height_band": [0.2, 1.5], "init": [1, 2, 0, 0, 0, 0]})"), "");
  // A field whose value is a list however long (a node's topics) takes one item, and no other field does.
  test::write_bytes(dir / "topics.yaml", "node: {topics: [points], sigma_hit: [1]}\n");
  const auto topics = [](const std::string& field) { return field == "node.topics"; };
  EXPECT_THROW(read_parameter_file((dir / "topics.yaml").string(), topics), Error);
  test::write_bytes(dir / "topics.yaml", "node: {topics: [points], sigma_hit: 1}\n");
  EXPECT_EQ(read_parameter_file((dir / "topics.yaml").string(), topics).at("node.topics"), "points");
  EXPECT_THROW(read_parameter_file((dir / "topics.yaml").string()), Error);
}

TEST(LocalizerParameters, TypesAreCheckedValueByValue) {
  EXPECT_NO_THROW(check_parameter_types({{"particles", "100"}, {"min_particles", "900000"}, {"sigma_hit", "0.2"}}))
      << "a value of the right kind passes, whatever the others (min_particles beyond max_particles)";
  const std::vector<std::pair<std::string, std::string>> wrong = {
      {"particles", "many"}, {"particles", "true"},   {"sigma_hit", "1,2"},      {"ignore_imu", "7"},
      {"backend", "cuda"},   {"init", "1,2,3"},       {"init_height_band", "1"}, {"update_min_a", "fast"},
      {"motion_model", "x"}, {"laser_sigma_hit", "w"}};
  for (const auto& [name, value] : wrong) {
    try {
      check_parameter_types({{"seed", "1"}, {name, value}});
      ADD_FAILURE() << name << " = " << value << " passed";
    } catch (const Error& e) {
      const std::string canonical = name == "laser_sigma_hit" ? "sigma_hit" : name;
      EXPECT_NE(std::string(e.what()).find(canonical), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace tsdf_mcl
