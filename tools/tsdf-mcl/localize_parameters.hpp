#pragma once
// The command line's adapter over the library's parameter schema (tsdf_mcl/localizer/localizer_parameters.hpp): its
// specs as options, a --config file under the command line, and the values into LocalizerOptions.
#include <string>
#include <vector>

#include "options.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::cli {

// The schema's parameters as options (with their --help groups).
std::vector<OptionSpec> localize_parameter_specs();
// Sets every value of a YAML/JSON file (read_parameter_file) that the command line did not give, after checking
// the file's values on their own: Error naming the file and the field for an unknown name or a bad value.
void apply_config(Options& o, const std::string& file);
// The schema's values from `o` (given on the command line or by a config file) into LocalizerOptions.
LocalizerOptions localizer_options(const Options& o);

}  // namespace tsdf_mcl::cli
