#include "tsdf_mcl/localization_state.hpp"

namespace tsdf_mcl {

LocalizationState localization_state(const FilterStep& step) {
  const PoseEstimate& e = step.estimate;
  if (e.converged) return LocalizationState::kConverged;
  if (step.implausible) return LocalizationState::kLost;
  if (e.hypotheses.size() >= 2 && e.hypotheses[1].weight >= kAmbiguousSecondWeight)
    return LocalizationState::kAmbiguous;
  return LocalizationState::kSearching;
}

const char* to_string(LocalizationState state) {
  switch (state) {
    case LocalizationState::kSearching:
      return "searching";
    case LocalizationState::kAmbiguous:
      return "ambiguous";
    case LocalizationState::kConverged:
      return "converged";
    case LocalizationState::kLost:
      return "lost";
  }
  return "?";
}

}  // namespace tsdf_mcl
