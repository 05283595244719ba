#pragma once
// Opening the files that inputs name. Only regular files are read: a FIFO or a device would block or never end,
// and every reader bounds the size before it allocates.
#include <cstdint>
#include <filesystem>
#include <string>

namespace tsdf_mcl {

// Size of the regular file `file`. Throws Error "WHAT FILE does not exist" / "is a directory" / "is not a regular
// file" / "is larger than the limit" (`what` names the kind of file: "map", "mesh", "scan", ...).
std::uint64_t input_file_size(const std::filesystem::path& file, const std::string& what, std::uint64_t max_bytes);
// The whole file, after the checks of input_file_size.
std::string read_input_file(const std::filesystem::path& file, const std::string& what, std::uint64_t max_bytes);

}  // namespace tsdf_mcl
