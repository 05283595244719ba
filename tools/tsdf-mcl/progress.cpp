#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::cli {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

}  // namespace

std::vector<OptionSpec> with_verbosity_options(std::vector<OptionSpec> specs) {
  specs.push_back({"quiet", "", "", "print only the summary (and errors)", "output"});
  specs.push_back({"verbose", "", "", "print a line per scan (the default is a progress line)", "output"});
  return specs;
}

Verbosity verbosity_of(const Options& o) {
  if (o.flag("quiet") && o.flag("verbose")) throw Error("--quiet and --verbose contradict each other");
  if (o.flag("quiet")) return Verbosity::kQuiet;
  return o.flag("verbose") ? Verbosity::kVerbose : Verbosity::kNormal;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return "?";
  const long s = std::lround(seconds);
  char buf[32];
  if (s < 60) {
    std::snprintf(buf, sizeof(buf), "%ld s", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld", s / 60, s % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  }
  return buf;
}

Progress::Progress(std::string command, Verbosity verbosity, std::string unit, double pipe_interval_s)
    : command_(std::move(command)),
      verbosity_(verbosity),
      unit_(std::move(unit)),
      tty_(::isatty(STDERR_FILENO) != 0),
      interval_s_(pipe_interval_s),
      started_(Clock::now()),
      last_print_(started_) {
  if (const char* env = std::getenv("TSDF_MCL_PROGRESS_INTERVAL")) {
    char* end = nullptr;
    const double v = std::strtod(env, &end);
    if (end != env && *end == '\0' && v >= 0.0 && std::isfinite(v)) interval_s_ = v;
  }
}

Progress::~Progress() { clear_live(); }

void Progress::clear_live() {
  if (!live_shown_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  live_shown_ = false;
}

std::string Progress::status_line(std::size_t done, std::size_t total, const std::string& status) const {
  const double elapsed = seconds_between(first_time_, Clock::now());
  const std::size_t counted = done - first_done_;
  std::string line = command_ + ": ";
  char buf[96];
  if (unit_.empty()) {
    std::snprintf(buf, sizeof(buf), "%s%s%.0f %%", status.c_str(), status.empty() ? "" : " ",
                  total == 0 ? 100.0 : 100.0 * static_cast<double>(done) / static_cast<double>(total));
    line += buf;
  } else {
    line += std::to_string(done) + "/" + std::to_string(total) + " " + unit_;
    if (!status.empty()) line += ", " + status;
  }
  if (counted >= 2 && elapsed > 0.0 && done < total) {
    const double rate = static_cast<double>(counted) / elapsed;
    if (!unit_.empty()) {
      std::snprintf(buf, sizeof(buf), ", %.1f %s/s", rate, unit_.c_str());
      line += buf;
    }
    line += ", ETA " + format_duration(static_cast<double>(total - done) / rate);
  }
  return line;
}

void Progress::update(std::size_t done, std::size_t total, const std::string& status, bool milestone) {
  if (verbosity_ == Verbosity::kQuiet) return;
  const auto now = Clock::now();
  if (!first_seen_) {
    first_seen_ = true;
    first_time_ = now;
    first_done_ = done;
  }
  const double since = seconds_between(last_print_, now);
  const std::string line = status_line(done, total, status);
  if (tty_ && verbosity_ == Verbosity::kNormal) {
    // Redrawing a terminal line costs little, but not more often than the eye can follow.
    if (milestone) {
      clear_live();
      std::fprintf(stderr, "%s\n", line.c_str());
    } else if (since >= 0.1 || done == total) {
      std::fprintf(stderr, "\r\033[K%s", line.substr(0, 99).c_str());
      live_shown_ = true;
    } else {
      return;
    }
    std::fflush(stderr);
    last_print_ = now;
    return;
  }
  if (verbosity_ == Verbosity::kVerbose && !milestone) return;  // the per-scan lines say it already
  // A line every interval at first, then as often as the run has lasted so far (at most a minute apart): a
  // short run shows its progress, a long one does not flood its log.
  const double interval =
      interval_s_ > 0.0 ? std::max(interval_s_, std::min(seconds_between(started_, now), 60.0)) : 0.0;
  if (!milestone && since < interval) return;
  std::fprintf(stderr, "%s\n", line.c_str());
  last_print_ = now;
}

void Progress::note(const std::string& line) {
  if (verbosity_ == Verbosity::kQuiet) return;
  clear_live();
  std::fprintf(stderr, "%s: %s\n", command_.c_str(), line.c_str());
}

void Progress::detail(const std::string& line) {
  if (verbosity_ != Verbosity::kVerbose) return;
  clear_live();
  std::fprintf(stderr, "%s\n", line.c_str());
}

void Progress::summary(const std::string& line) {
  clear_live();
  std::fprintf(stderr, "%s: %s\n", command_.c_str(), line.c_str());
}

}  // namespace tsdf_mcl::cli
