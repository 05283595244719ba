#pragma once
// Recovery from a lost track (augmented MCL, Thrun et al. "Probabilistic Robotics" 8.3.5): a short-term and a
// long-term average of the measurement fit; while the short-term one is below the long-term one, random
// particles are drawn uniformly over the map, in proportion to 1 - w_fast / w_slow.
//
// One change to the textbook rule: w_slow is discounted by a margin first, share = 1 - w_fast / (w_slow (1 -
// margin)). The fit of a correct track varies with the place (how much of the scan the map explains) and
// with the spread of the particle cloud; on real data it dips 20-30 % below its long-term average now and
// then, and without a margin each dip floods a converged filter with random particles. A lost track's fit
// falls by an order of magnitude, far beyond the margin.
//
// The fit fed in must mean the same thing whatever the particle and point counts: the mean over particles of
// the per-point geometric-mean likelihood (WeightSummary::fit_sum / n). Normalized weights sum to 1 by
// construction and carry no information about how well the scan matches the map.
#include <cstddef>

namespace tsdf_mcl {

class RecoveryMonitor {
 public:
  // nav2 semantics: 0 < alpha_slow << alpha_fast; either one 0 disables recovery. margin in [0, 1).
  RecoveryMonitor(double alpha_slow, double alpha_fast, double margin = 0.0);

  // Feeds one fit value; returns the share of random particles for the next generation, in [0, 1].
  double update(double fit);
  // Forgets both averages (a new initialization); the next fit starts them again.
  void reset() {
    w_slow_ = w_fast_ = 0.0;
    samples_ = 0;
  }

  bool enabled() const { return alpha_slow_ > 0.0 && alpha_fast_ > 0.0; }
  double w_slow() const { return w_slow_; }
  double w_fast() const { return w_fast_; }

 private:
  double alpha_slow_;
  double alpha_fast_;
  double margin_;
  double w_slow_ = 0.0;
  double w_fast_ = 0.0;
  std::size_t samples_ = 0;
};

}  // namespace tsdf_mcl
