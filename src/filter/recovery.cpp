#include "tsdf_mcl/filter/recovery.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"

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
  // Until 1/alpha samples have come, an average is the plain mean of those seen: started at the first sample
  // with the rate alpha, w_slow would remember one lucky first fit for a hundred updates.
  ++samples_;
  const double n = static_cast<double>(samples_);
  w_slow_ += std::max(alpha_slow_, 1.0 / n) * (fit - w_slow_);
  w_fast_ += std::max(alpha_fast_, 1.0 / n) * (fit - w_fast_);
  if (!(w_slow_ > 0.0)) return 0.0;
  return std::clamp(1.0 - w_fast_ / (w_slow_ * (1.0 - margin_)), 0.0, 1.0);
}

}  // namespace tsdf_mcl
