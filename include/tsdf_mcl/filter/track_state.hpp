#pragma once
// What the localizer can say about its track, in one word, for the CLI summary, report.json and a ROS node's
// /diagnostics. Classified by the filter (ParticleFilter: FilterStep::state), never by a frontend.
#include <cstddef>
#include <optional>
#include <string>

namespace tsdf_mcl {

enum class TrackState {
  kSearching,  // no track yet: a global belief, or a search started again after a wrong lock
  kTracking,   // a track that converged before follows the map, not (or not yet again) converged
  kAmbiguous,  // another place explains the scans nearly as well, or a challenger is being proven (track_keeper.hpp)
  kConverged,  // ConvergenceMonitor's promise: the track is right as far as the data can tell
  kUnmapped,   // tracking through unmapped space: the map covers too little of the scan, odometry carries the pose
               // and its covariance grows
  kLost,       // the fit says the track is wrong: recovery searches the map again
};
constexpr std::size_t kTrackStates = 6;

// "searching", "tracking", "ambiguous", "converged", "unmapped", "lost".
const char* to_string(TrackState state);
// The inverse of to_string (nullopt for anything else).
std::optional<TrackState> parse_track_state(const std::string& name);

}  // namespace tsdf_mcl
