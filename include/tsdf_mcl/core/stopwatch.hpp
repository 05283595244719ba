#pragma once
// Wall-clock time of a stage, for the timings that report.json, bench and the per-scan lines print. Steady clock:
// it never jumps with the system time.
#include <chrono>

namespace tsdf_mcl {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  // Milliseconds since construction.
  double ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace tsdf_mcl
