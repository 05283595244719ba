#pragma once
// An output folder that a run replaces as a whole. Files are written into a staging folder beside it; only a run
// that completes moves them in, replacing everything a previous run left under the same names (also names this run
// did not write). A failed run leaves the folder as it was: a previous run's complete results, or nothing.
#include <filesystem>
#include <string>
#include <vector>

namespace tsdf_mcl::cli {

class StagedOutputFolder {
 public:
  // Checks, before any work starts, that `folder` can be written (an existing folder, or a new one in an existing
  // folder) and creates the staging folder. `names` are the files and folders a run writes. Throws Error.
  StagedOutputFolder(const std::filesystem::path& folder, std::vector<std::string> names);
  ~StagedOutputFolder();  // removes the staging folder: an uncommitted run's files, or the replaced results
  StagedOutputFolder(const StagedOutputFolder&) = delete;
  StagedOutputFolder& operator=(const StagedOutputFolder&) = delete;

  const std::filesystem::path& staging() const { return staging_; }  // where the run writes
  const std::filesystem::path& folder() const { return folder_; }    // where the results will be
  // Moves the results into the folder. Throws Error if a move fails.
  void commit();

 private:
  std::filesystem::path folder_;
  std::filesystem::path staging_;
  std::vector<std::string> names_;
};

}  // namespace tsdf_mcl::cli
