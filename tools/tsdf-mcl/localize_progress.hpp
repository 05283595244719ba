#pragma once
// What tsdf-mcl localize tells a person while it runs: the progress line (scans/s, particles, state, ETA), the
// state changes with their reasons (searching -> ambiguous -> converged -> lost), why an initial pose is being searched
// around, and the per-scan lines of --verbose.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "progress.hpp"
#include "tsdf_mcl/filter/track_state.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::cli {

class LocalizeNarrator {
 public:
  LocalizeNarrator(Progress& progress, const LocalizerOptions& options, std::size_t total_scans);

  // Scan `index` (the dataset's numbering), the k-th of the run (0-based), with `dropped` non-finite points.
  void scan(std::size_t k, std::size_t index, const ScanRecord& record, std::size_t dropped);

  // The scan (dataset numbering) of the filter's first converged flag, if it ever raised it.
  std::optional<std::size_t> first_converged_scan() const { return first_converged_; }
  // "converged (the filter's flag) since scan 32" / "NOT converged: the filter never claimed convergence" / ...
  std::string verdict(const RunSummary& summary, std::optional<std::size_t> converged_since_scan) const;

 private:
  void explain_initial_fit(std::size_t index, const FilterStep& step);
  void detail_line(std::size_t k, std::size_t index, const ScanRecord& record, std::size_t dropped);

  Progress& progress_;
  LocalizerOptions options_;
  std::size_t total_;
  TrackState reported_ = TrackState::kSearching;
  bool explained_fit_ = false;
  bool searching_noted_ = false;
  std::size_t dropped_scans_ = 0;
  std::optional<std::size_t> first_converged_;
};

}  // namespace tsdf_mcl::cli
