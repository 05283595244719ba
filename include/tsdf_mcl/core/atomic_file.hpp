#pragma once
// Writing outputs so that a failure (full disk, killed process) never leaves a partial file: everything is written
// to a temporary file beside the target, flushed to disk and renamed over the target. The target then holds the
// complete old contents or the complete new ones.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace tsdf_mcl {

// Writes `bytes` to `file`. Throws Error naming `what` and the file if any step fails; the temporary is removed.
void write_file_atomically(const std::filesystem::path& file, std::string_view bytes, const std::string& what);
// For writers that need a path of their own (PNG encoders, stdio): `write` fills the temporary path it is given.
void write_file_atomically(const std::filesystem::path& file,
                           const std::function<void(const std::filesystem::path& temporary)>& write,
                           const std::string& what);

// Checks, before any work starts, that `file` can be written: its folder exists, it is not itself a folder, and a
// file can be created beside it. Throws Error naming `what` and the reason.
void check_output_file(const std::filesystem::path& file, const std::string& what);

}  // namespace tsdf_mcl
