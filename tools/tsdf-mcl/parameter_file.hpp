#pragma once
// Parameter files (tsdf-mcl localize --config): YAML or JSON, read into option names and values.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace tsdf_mcl {

// Nested maps join their keys with '.' ({a: {b: 1}} -> "a.b" = "1"), lists become comma-separated values. Throws
// Error naming the file if it is missing, not a regular file, larger than limits::kMaxConfigFileBytes, not valid
// YAML/JSON, not a map, nested too deeply, or holds more than limits::kMaxConfigValues values once YAML aliases
// are followed (an alias repeats a subtree, so a kilobyte of aliases can name billions of values).
std::vector<std::pair<std::string, std::string>> read_parameter_file(const std::filesystem::path& file);

}  // namespace tsdf_mcl
