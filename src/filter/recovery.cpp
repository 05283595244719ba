#include "tsdf_mcl/recovery.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {

RecoveryMonitor::RecoveryMonitor(double alpha_slow, double alpha_fast, double margin)
    : alpha_slow_(alpha_slow), alpha_fast_(alpha_fast), margin_(margin) {
  if (!(margin >= 0.0 && margin < 1.0)) throw Error("recovery_margin must lie in [0, 1)");
  if (!(alpha_slow >= 0.0 && alpha_slow <= 1.0)) throw Error("recovery_alpha_slow must lie in [0, 1]");
  if (!(alpha_fast >= 0.0 && alpha_fast <= 1.0)) throw Error("recovery_alpha_fast must lie in [0, 1]");
  if (alpha_slow > 0.0 && alpha_fast > 0.0 && !(alpha_fast > alpha_slow)) {
    throw Error("recovery_alpha_fast must be larger than recovery_alpha_slow");
  }
}

double RecoveryMonitor::update(double fit) {
  if (!enabled() || !(fit >= 0.0) || !std::isfinite(fit)) return 0.0;
  w_slow_ = w_slow_ == 0.0 ? fit : w_slow_ + alpha_slow_ * (fit - w_slow_);
  w_fast_ = w_fast_ == 0.0 ? fit : w_fast_ + alpha_fast_ * (fit - w_fast_);
  if (!(w_slow_ > 0.0)) return 0.0;
  return std::clamp(1.0 - w_fast_ / (w_slow_ * (1.0 - margin_)), 0.0, 1.0);
}

}  // namespace tsdf_mcl
