#include "localize_parameters.hpp"

#include <map>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"

namespace tsdf_mcl::cli {

std::vector<OptionSpec> localize_parameter_specs() {
  std::vector<OptionSpec> specs;
  for (const ParameterSpec& s : localizer_parameter_specs()) {
    specs.push_back({s.name, s.value_name, s.default_value, s.help, s.group});
  }
  return specs;
}

namespace {

// The schema's values the command line (or a config file already applied) gave.
std::map<std::string, std::string> given_values(const Options& o) {
  std::map<std::string, std::string> values;
  for (const ParameterSpec& s : localizer_parameter_specs()) {
    if (!o.has(s.name)) continue;
    values[s.name] = s.value_name.empty() ? (o.flag(s.name) ? "true" : "false") : o.text(s.name);
  }
  return values;
}

}  // namespace

void apply_config(Options& o, const std::string& file) {
  std::map<std::string, std::string> values;
  try {
    values = canonical_parameters(read_parameter_file(file));
    check_parameter_types(values);  // also the values the command line overrides below
  } catch (const Error& e) {
    const std::string what = e.what();
    throw Error(what.rfind(file, 0) == 0 ? what : file + ": " + what);
  }
  // The file's values under the command line's, checked now so that an error about a value the file gave names
  // the file (errors name their parameter first).
  std::map<std::string, std::string> merged = values;
  const std::map<std::string, std::string> given = given_values(o);
  for (const auto& [name, value] : given) merged[name] = value;
  try {
    localizer_options_from(merged);
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const auto& [name, value] : values) {
      if (!given.count(name) && what.rfind(name, 0) == 0 && what.size() > name.size() &&
          (what[name.size()] == ' ' || what[name.size()] == ':')) {
        throw Error(file + ": " + what);
      }
    }
    throw;
  }
  for (const auto& [name, value] : values) o.set_default_from_config(name, value);
}

LocalizerOptions localizer_options(const Options& o) { return localizer_options_from(given_values(o)); }

}  // namespace tsdf_mcl::cli
