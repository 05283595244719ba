#pragma once
// The localization parameters every frontend shares (tsdf-mcl localize, the ROS node): their option specs with
// nav2 AMCL's names and defaults, and their translation into LocalizerOptions with the same validation. A frontend
// adds its own inputs (map, dataset, topics) to the specs and fills Options from its command line, a config file
// or a parameter server.
#include <optional>
#include <string>
#include <vector>

#include "options.hpp"
#include "tsdf_mcl/localizer.hpp"

namespace tsdf_mcl::cli {

// Filter, scan preprocessing, initialization, backend and seed; angles in radians.
std::vector<OptionSpec> localize_parameter_specs();
// Sets every value of a YAML/JSON file (read_parameter_file) that the command line did not give; Error naming
// the file for an unknown parameter.
void apply_config(Options& o, const std::string& file);
FilterParameters filter_parameters(const Options& o);
ScanPreprocessing scan_parameters(const Options& o);
// The initial pose of init x,y,z,roll,pitch,yaw or init initial_pose; nullopt for global.
std::optional<Pose> initial_pose(const Options& o);
// All of the above plus backend, cpu_threads and ignore_imu.
LocalizerOptions localizer_options(const Options& o);

}  // namespace tsdf_mcl::cli
