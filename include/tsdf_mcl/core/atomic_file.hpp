#pragma once
// Writing outputs so that a failure (full disk, killed process) never leaves a partial file: everything is written
// to a temporary file beside the target, flushed to disk and renamed over the target. The target then holds the
// complete old contents or the complete new ones.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace tsdf_mcl {

// An output replaces only a regular file (or creates one): a device (/dev/null, /dev/full), a FIFO or a socket at
// `file`, or a link to one, is refused instead of being replaced by a regular file. Temporaries that a killed
// writer left beside `file` (FILE.partial-PID-N of a process that no longer runs) are removed first.
//
// Writes `bytes` to `file`. Throws Error naming `what` and the file if any step fails; the temporary is removed.
void write_file_atomically(const std::filesystem::path& file, std::string_view bytes, const std::string& what);
// For writers that need a path of their own (PNG encoders, stdio): `write` fills the temporary path it is given.
void write_file_atomically(const std::filesystem::path& file,
                           const std::function<void(const std::filesystem::path& temporary)>& write,
                           const std::string& what);

// Checks, before any work starts, that `file` can be written: its folder exists, it is not itself a folder nor
// anything else but a regular file, it is none of `inputs` (the files the command reads; `build-map --mesh box.obj
// -o box.obj`), and a file can be created beside it. Throws Error naming `what` and the reason.
void check_output_file(const std::filesystem::path& file, const std::string& what,
                       const std::vector<std::filesystem::path>& inputs = {});

// Removes the entries of `folder` named PREFIX + PID (+ "-N") whose process no longer runs: the temporaries of a
// writer killed by a timeout or a signal, which cannot remove its own. A live process's, or one of another user's,
// stay.
void remove_stale_partials(const std::filesystem::path& folder, const std::string& prefix);

}  // namespace tsdf_mcl
