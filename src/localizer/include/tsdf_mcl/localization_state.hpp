#pragma once
// The localization state a person or a robot reads off a filter step: searching (no dominant hypothesis yet),
// ambiguous (a second hypothesis holds a real share of the belief), converged (the filter's own flag: its
// convergence tests held), lost (the dominant hypothesis no longer fits the scan). Frontends print or publish it
// (tsdf-mcl localize's progress line).
#include "tsdf_mcl/particle_filter.hpp"

namespace tsdf_mcl {

enum class LocalizationState { kSearching, kAmbiguous, kConverged, kLost };

// A second hypothesis holding at least this share of the weight makes the belief ambiguous.
inline constexpr double kAmbiguousSecondWeight = 0.1;

LocalizationState localization_state(const FilterStep& step);
const char* to_string(LocalizationState state);

}  // namespace tsdf_mcl
