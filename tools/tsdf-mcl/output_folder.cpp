#include "output_folder.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"

namespace tsdf_mcl::cli {
namespace fs = std::filesystem;

namespace {

// Removes `.NAME.partial-PID` folders beside `folder` whose process no longer runs (a run killed by a timeout or
// a signal cannot remove its own); a live process's, or one of another user's, stays.
void remove_stale_partials(const fs::path& folder) {
  const std::string prefix = "." + folder.filename().string() + ".partial-";
  std::error_code ec;
  for (fs::directory_iterator it(folder.parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    long pid = 0;
    const auto [ptr, err] = std::from_chars(digits.data(), digits.data() + digits.size(), pid);
    if (digits.empty() || err != std::errc() || ptr != digits.data() + digits.size() || pid <= 0) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

}  // namespace

StagedOutputFolder::StagedOutputFolder(const fs::path& folder, std::vector<std::string> names)
    : names_(std::move(names)) {
  if (folder.empty()) throw Error("-o needs a folder name");
  // "run/" and "run" are the same folder; the staging folder goes beside it, on the same file system.
  folder_ = fs::absolute(folder).lexically_normal();
  if (folder_.filename().empty()) folder_ = folder_.parent_path();
  std::error_code ec;
  if (fs::exists(folder_, ec) && !fs::is_directory(folder_, ec)) {
    throw Error("output folder " + folder.string() + " is a file, not a folder");
  }
  if (!fs::is_directory(folder_.parent_path(), ec)) {
    throw Error("cannot create output folder " + folder.string() + ": " + folder_.parent_path().string() +
                " does not exist");
  }
  if (fs::is_directory(folder_, ec)) check_output_file(folder_ / names_.front(), "results into");
  remove_stale_partials(folder_);
  staging_ = folder_.parent_path() / ("." + folder_.filename().string() + ".partial-" + std::to_string(::getpid()));
  fs::remove_all(staging_, ec);
  if (!fs::create_directory(staging_, ec) || ec) {
    throw Error("cannot write output folder " + folder.string() + ": cannot create " + staging_.string() +
                (ec ? ": " + ec.message() : std::string()));
  }
}

StagedOutputFolder::~StagedOutputFolder() {
  std::error_code ignored;
  fs::remove_all(staging_, ignored);
}

void StagedOutputFolder::commit() {
  std::error_code ec;
  fs::create_directories(folder_, ec);
  if (ec) throw Error("cannot create output folder " + folder_.string() + ": " + ec.message());
  // The previous run's results go into the staging folder first (a folder cannot be renamed over a non-empty one),
  // and are deleted with it.
  const fs::path previous = staging_ / ".previous";
  fs::create_directory(previous, ec);
  for (const std::string& name : names_) {
    if (fs::exists(folder_ / name, ec)) {
      fs::rename(folder_ / name, previous / name, ec);
      if (ec) throw Error("cannot replace " + (folder_ / name).string() + ": " + ec.message());
    }
    if (fs::exists(staging_ / name, ec)) {
      fs::rename(staging_ / name, folder_ / name, ec);
      if (ec) throw Error("cannot move " + name + " into " + folder_.string() + ": " + ec.message());
    }
  }
}

}  // namespace tsdf_mcl::cli
