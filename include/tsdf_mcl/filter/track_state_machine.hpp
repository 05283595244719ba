#pragma once
// The filter's one state machine (track_state.hpp), with explicit hysteresis: `converged` is entered on strict
// conditions and left only on evidence that the track is wrong or no longer supported, never because a spread or a
// fit crossed a line. A robot gates on that flag; it must not stop and go with the noise of one scan.
//
// Entered when all of these hold for min_updates updates in a row at one place (the place moved as the odometry says):
//   - the dominant place holds the belief, concentrated (PoseEstimateOptions: converged_weight, converged_std_*);
//   - the scan fits there as a correct track's does: inlier ratio at least min_inliers, map coverage at least
//     min_coverage (absolute, calibrated on data: a running average may have started at a wrong lock);
//   - the place ledger (place_ledger.hpp) has refuted every rival and no challenger is being weighed;
//   - the background search has weighed the place (a lone lock is questioned before it is believed);
//   - after a change of mind (the track moved to another place, or a wrong lock was found out), the new place has
//     held over travel_after_change_m of odometry: the search that chose wrong once may choose a look-alike again.
// Left only when:
//   - the fit at the track is implausible where the map covers its scan, or recovery moves most of the belief: lost;
//   - the belief moved to a challenger (its heaviest place lies elsewhere: the evidence between places moved it), the
//     ledger proves a rival better than the track, or takes a challenger: ambiguous;
//   - the map covers less than min_coverage of the scan at the track: unmapped, and converged again once it covers
//     most of the scan (the share at which the fit judges a track, PlaceOptions::most_of_the_scan);
//   - the map covers the scan but it fits the track worse than a claim needs (inlier ratio under min_inliers: a robot
//     carried elsewhere, before the evidence between places has spoken): searching, and claimed again as at first.
// A spread, a dip of the fit within what a claim needs or a newly found look-alike does not end it: the ledger weighs
// a look-alike, and the claim ends when the evidence proves it or the belief leaves the track for it.
#include <cstddef>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/same_place.hpp"
#include "tsdf_mcl/filter/track_state.hpp"

namespace tsdf_mcl {

struct StateOptions {
  double min_inliers = 0.5;            // converged_min_inliers
  double min_coverage = 0.5;           // converged_min_coverage
  std::size_t min_updates = 3;         // converged_min_updates
  double travel_after_change_m = 5.0;  // converged_travel_after_jump
  double ambiguous_weight = 0.1;       // a second place holding this share makes a belief ambiguous

  void validate() const;  // throws Error naming the parameter
};

// What one filter update says, for the state machine.
struct StateEvidence {
  Pose place;                  // the place the estimate reports (the track)
  Pose motion;                 // odometry since the last update (identity without)
  bool concentrated = false;   // the dominant place holds the belief, compact
  double inliers = 0.0;        // inlier ratio at the place (over its observed points)
  double coverage = 1.0;       // map coverage there
  double second_weight = 0.0;  // the second place's share of the belief
  bool searched = true;        // the background search has weighed the belief since it concentrated
  bool rival_undecided = false;
  bool rival_proven = false;
  bool holding = false;        // the belief moved to a challenger the ledger has not decided
  bool implausible = false;    // the fit at the track is implausible (two updates)
  bool recovery_lost = false;  // recovery moves most of the belief elsewhere
};

class TrackStateMachine {
 public:
  // `judged_coverage`: the map coverage at which the fit judges a track (PlaceOptions::most_of_the_scan).
  TrackStateMachine(const StateOptions& options, const SamePlace& same_place, double judged_coverage = 0.75);

  // A new start (an initialization): searching.
  void reset();
  // The filter found out it was wrong (the state stays what this update said, lost): the counts start over, and the
  // next place must hold over travel_after_change_m.
  void restart_after_wrong_lock();
  // One update; returns the new state (reason()).
  TrackState update(const StateEvidence& e);

  TrackState state() const { return state_; }
  StateReason reason() const { return reason_; }
  bool converged() const { return state_ == TrackState::kConverged; }
  // A converged track not given up since: converged or carried through unmapped space.
  bool holds_track() const { return state_ == TrackState::kConverged || state_ == TrackState::kUnmapped; }
  bool converged_once() const { return converged_once_; }
  std::size_t streak() const { return streak_; }

 private:
  void count_persistence(const StateEvidence& e, bool same_place, bool ready);
  void set(TrackState s, StateReason r);
  TrackState hold(const StateEvidence& e, bool same_place);
  TrackState claim(const StateEvidence& e);

  StateOptions options_;
  SamePlace same_place_;
  double judged_coverage_;
  TrackState state_ = TrackState::kSearching;
  StateReason reason_ = StateReason::kSpread;
  std::size_t streak_ = 0;
  Pose last_ = Pose::Identity();
  bool started_ = false;
  bool converged_once_ = false;       // since reset(): a jump after it needs travel_after_change_m
  bool concentrated_before_ = false;  // the last update's belief was concentrated: a jump from it needs it too
  bool changed_ = false;              // a change of mind not yet proven by travel
  double travel_ = 0.0;               // m of odometry since the streak started
};

}  // namespace tsdf_mcl
