#pragma once
// The localization parameters as one table the library owns: name (nav2 AMCL's where the meaning carries over),
// value name, default, help and --help group, and their translation into LocalizerOptions with one validation.
// Every frontend is a plain adapter over it: tsdf-mcl localize (command line), YAML/JSON parameter files
// (parameter_file.hpp), the ROS node (parameter server) and the Python bindings.
//
//   std::map<std::string, std::string> values = read_parameter_file("params.yaml");
//   values["particles"] = "5000";
//   const LocalizerOptions options = localizer_options_from(values);   // throws Error naming the parameter
//
// Angles: nav2-named parameters keep nav2's radians (initial_pose.yaw, update_min_a, ...); every angle also takes
// an explicit unit suffix ("90deg", "1.57rad"), and a bare value beyond a full turn is rejected with that hint.
#include <map>
#include <string>
#include <vector>

#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl {

struct ParameterSpec {
  std::string name;           // as on the command line without "--"; nested names use '.' (initial_pose.x)
  std::string value_name;     // M, RAD, N, ...; empty for a flag (true/false)
  std::string default_value;  // as text; empty = none
  std::string help;
  std::string group;  // "initialization", "filter", "sensor model" or "advanced" (localize --help's sections)
};

// Every parameter localizer_options_from() reads, in --help order (essentials first within a group).
const std::vector<ParameterSpec>& localizer_parameter_specs();

// docs/parameters.md: every parameter of the table by group, with its value, default and help, and the amcl aliases
// (`tsdf-mcl localize --help-markdown` prints it; a test keeps the file equal to it).
std::string parameters_markdown();

// ROS 1 amcl's names accepted for ours where the meaning carries over (laser_max_beams -> max_beams, odom_alpha1
// -> alpha1, kld_err -> pf_err, ...). odom_model_type's values (diff, omni, diff-corrected, omni-corrected) all
// mean motion_model odometry.
struct ParameterAlias {
  std::string alias, name;
};
const std::vector<ParameterAlias>& localizer_parameter_aliases();

// The values by the schema's names: amcl aliases resolved (an alias given beside its parameter is an Error), every
// name checked (Error "unknown parameter 'NAME' (did you mean ...?)"), no value with a NUL character.
std::map<std::string, std::string> canonical_parameters(const std::map<std::string, std::string>& values);

// LocalizerOptions from name -> text values (the schema's names or their amcl aliases); names not given keep their
// defaults. Flags take true/false (1/0, yes/no, on/off). Throws Error naming the parameter for an unknown name
// (with the closest known names), an alias given beside its parameter, or an invalid value.
LocalizerOptions localizer_options_from(const std::map<std::string, std::string>& values);

// Throws Error naming the parameter for a value that is not of its parameter's kind (a word for a number, a number
// or a list for a flag, a name that is not among its choices), each value judged alone: a parameter file's value
// that the command line overrides is checked too. Ranges and the values' agreement are localizer_options_from's.
void check_parameter_types(const std::map<std::string, std::string>& values);

// The known names closest to a mistyped one (edit distance, at most three, best first; empty if none is close):
// the "did you mean" of every frontend.
std::vector<std::string> closest_names(const std::string& name, const std::vector<std::string>& known);
// " (did you mean a, b?)" for closest_names, or "" when none is close.
std::string did_you_mean(const std::string& name, const std::vector<std::string>& known,
                         const std::string& prefix = "");

// An angle as text: radians, or with an explicit "deg"/"rad" suffix. Throws Error naming `what` for a non-number or
// a magnitude beyond max_abs radians (a bare value that large reads as degrees: the hint says to write "deg").
double parse_angle(const std::string& text, const std::string& what, double max_abs);

}  // namespace tsdf_mcl
