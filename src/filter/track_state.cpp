#include "tsdf_mcl/filter/track_state.hpp"

namespace tsdf_mcl {

const char* to_string(TrackState state) {
  switch (state) {
    case TrackState::kSearching:
      return "searching";
    case TrackState::kAmbiguous:
      return "ambiguous";
    case TrackState::kConverged:
      return "converged";
    case TrackState::kUnmapped:
      return "unmapped";
    case TrackState::kLost:
      return "lost";
  }
  return "searching";
}

std::optional<TrackState> parse_track_state(const std::string& name) {
  for (std::size_t k = 0; k < kTrackStates; ++k) {
    const auto s = static_cast<TrackState>(k);
    if (name == to_string(s)) return s;
  }
  return std::nullopt;
}

const char* to_string(StateReason reason) {
  switch (reason) {
    case StateReason::kSpread:
      return "no compact place holds the belief";
    case StateReason::kPersisting:
      return "a place holds the belief, not yet long enough";
    case StateReason::kPoorFit:
      return "the place explains too little of the scan";
    case StateReason::kSearchPending:
      return "the background search has not weighed the place yet";
    case StateReason::kRivalUndecided:
      return "a look-alike not yet refuted";
    case StateReason::kSecondPlace:
      return "a second place holds a share of the belief";
    case StateReason::kChangeOfMind:
      return "the track moved: the new place must hold over travel";
    case StateReason::kRivalProven:
      return "a look-alike proved better than the track";
    case StateReason::kChallenged:
      return "the belief moved to a challenger the ledger has not proven; the estimate holds the track";
    case StateReason::kProven:
      return "every rival refuted";
    case StateReason::kMapCoversLittle:
      return "the map covers too little of the scan";
    case StateReason::kImplausibleFit:
      return "the fit at the track is implausible";
    case StateReason::kRecovery:
      return "recovery moved most of the belief";
  }
  return "";
}

}  // namespace tsdf_mcl
