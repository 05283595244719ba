#pragma once
// Parameter files (tsdf-mcl localize --config, the Python bindings): YAML or JSON, read into parameter names and
// values as text for localizer_options_from (localizer_parameters.hpp).
#include <functional>
#include <map>
#include <string>

namespace tsdf_mcl {

// Nested maps join their keys with '.' ({a: {b: 1}} -> "a.b" = "1"), lists of two or more items become
// comma-separated values; so do lists of one item for the fields `list_field` names (a ROS node's topics), whose
// value is a list however long. Throws Error naming the file (and the field, where one is at fault) if it is missing,
// not a regular file, larger than limits::kMaxConfigFileBytes, not UTF-8 text (UTF-16/32, NUL bytes), not valid
// YAML/JSON (a .json file is held to JSON: no trailing comma), more than one YAML document, not a map, names a
// field twice, holds a list of fewer than two items, a value with a control character (a NUL inside "0.1\0junk"), a
// JSON number beyond the range of a double, is nested too deeply, or holds more than limits::kMaxConfigValues
// values once YAML aliases are followed (an alias repeats a subtree, so a kilobyte of aliases can name billions of
// values).
std::map<std::string, std::string> read_parameter_file(
    const std::string& path, const std::function<bool(const std::string& field)>& list_field = {});

}  // namespace tsdf_mcl
