#pragma once
// What the localizer can say about its track, in one word and a reason, for the CLI, report.json, the ROS nodes'
// /diagnostics and Python. Decided by the filter's state machine (track_state_machine.hpp), never by a frontend.
#include <cstddef>
#include <optional>
#include <string>

namespace tsdf_mcl {

enum class TrackState {
  kSearching,  // no track to claim yet: the belief is spread, or a place holds it but has not yet earned the claim
  kAmbiguous,  // places the scans have not told apart, or a challenger of the track is being weighed
  kConverged,  // the track is right as far as the data can tell: a robot may act on it
  kUnmapped,   // a converged track carried through space the map does not cover (odometry holds the pose)
  kLost,       // the fit says the track is wrong: the filter searches the map again
};
constexpr std::size_t kTrackStates = 5;

// Why the state is what it is; every change of state carries one.
enum class StateReason {
  kSpread,           // no compact place holds the belief
  kPersisting,       // a place holds the belief, not yet for converged_min_updates updates
  kPoorFit,          // the place explains too little of the scan to be claimed (inliers or coverage)
  kSearchPending,    // the background search has not yet weighed the place
  kRivalUndecided,   // a look-alike the scans have not refuted
  kSecondPlace,      // another place holds ambiguous_weight of the belief
  kChangeOfMind,     // the track moved to another place: it must hold over converged_travel_after_jump first
  kRivalProven,      // a look-alike proved better than the track
  kChallenged,       // converged; the belief moved to a challenger that is not proven: the estimate holds the track
  kProven,           // converged: every rival refuted, the place held, the fit plausible
  kMapCoversLittle,  // the map covers too little of the scan at the track
  kImplausibleFit,   // the fit at the track is implausible where the map covers the scan
  kRecovery,         // recovery moved most of the belief elsewhere
};
constexpr std::size_t kStateReasons = 13;

// "searching", "ambiguous", "converged", "unmapped", "lost".
const char* to_string(TrackState state);
// The inverse of to_string (nullopt for anything else).
std::optional<TrackState> parse_track_state(const std::string& name);
// A short phrase, e.g. "a look-alike not yet refuted".
const char* to_string(StateReason reason);

}  // namespace tsdf_mcl
