#pragma once
// Progress of a long command on stderr. On a terminal one live status line, rewritten in place; in a pipe or a
// log a line after 5 s, then at intervals as long as the run so far (at most a minute), and at each milestone
// (a state change); --verbose adds the per-item lines,
// --quiet leaves only the command's summary.
#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

#include "options.hpp"

namespace tsdf_mcl::cli {

enum class Verbosity { kQuiet, kNormal, kVerbose };

// Appends --quiet and --verbose (group "output").
std::vector<OptionSpec> with_verbosity_options(std::vector<OptionSpec> specs);
// From --quiet / --verbose; Error if both are given.
Verbosity verbosity_of(const Options& o);

class Progress {
 public:
  // `command` prefixes every line; `unit` names the items ("scans": "120/1833 scans, 45.2 scans/s"; empty: a
  // percentage); a line every `pipe_interval_s` in a pipe (TSDF_MCL_PROGRESS_INTERVAL overrides it).
  Progress(std::string command, Verbosity verbosity, std::string unit = "", double pipe_interval_s = 5.0);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // `done` of `total` items (scans, frames); `status` what is going on. A milestone always prints (in a pipe a
  // line of its own, on a terminal it is also kept above the live line).
  void update(std::size_t done, std::size_t total, const std::string& status, bool milestone = false);
  // A line for a person (what was loaded, a warning): not with --quiet.
  void note(const std::string& line);
  // A per-item line: only with --verbose.
  void detail(const std::string& line);
  // The summary: printed at every verbosity, after the live line is cleared.
  void summary(const std::string& line);

  bool verbose() const { return verbosity_ == Verbosity::kVerbose; }
  bool tty() const { return tty_; }

 private:
  void clear_live();
  std::string status_line(std::size_t done, std::size_t total, const std::string& status) const;

  std::string command_;
  Verbosity verbosity_;
  std::string unit_;
  bool tty_;
  double interval_s_;
  std::chrono::steady_clock::time_point started_, last_print_;
  // The rate is measured from the first update on (set-up before it, a map load or a global search, is no item).
  std::chrono::steady_clock::time_point first_time_;
  std::size_t first_done_ = 0;
  bool first_seen_ = false;
  bool live_shown_ = false;
};

// "1:05" / "12 s" for an ETA.
std::string format_duration(double seconds);

}  // namespace tsdf_mcl::cli
