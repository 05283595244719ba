#include "tsdf_mcl/filter/track_state_machine.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {

void SamePlace::validate() const {
  if (!(max_m > 0.0) || !std::isfinite(max_m)) throw Error("converged_max_jump must be positive (m)");
  if (!(max_rad > 0.0) || !std::isfinite(max_rad)) throw Error("same place: the angle must be positive");
}

void StateOptions::validate() const {
  if (!(min_inliers >= 0.0 && min_inliers <= 1.0)) throw Error("converged_min_inliers must lie in [0, 1]");
  if (!(min_coverage >= 0.0 && min_coverage <= 1.0)) throw Error("converged_min_coverage must lie in [0, 1]");
  if (min_updates == 0) throw Error("converged_min_updates must be at least 1");
  if (!(travel_after_change_m >= 0.0) || !std::isfinite(travel_after_change_m))
    throw Error("converged_travel_after_jump must not be negative");
  if (!(ambiguous_weight >= 0.0 && ambiguous_weight <= 1.0)) throw Error("ambiguous_weight must lie in [0, 1]");
}

TrackStateMachine::TrackStateMachine(const StateOptions& options, const SamePlace& same_place, double judged_coverage)
    : options_(options), same_place_(same_place), judged_coverage_(std::max(judged_coverage, options.min_coverage)) {
  options_.validate();
  same_place_.validate();
}

void TrackStateMachine::reset() {
  restart_after_wrong_lock();
  changed_ = false;
  state_ = TrackState::kSearching;
  reason_ = StateReason::kSpread;
}

void TrackStateMachine::restart_after_wrong_lock() {
  streak_ = 0;
  last_ = Pose::Identity();
  started_ = false;
  converged_once_ = false;
  concentrated_before_ = false;
  changed_ = true;
  travel_ = 0.0;
}

void TrackStateMachine::set(TrackState s, StateReason r) {
  state_ = s;
  reason_ = r;
}

void TrackStateMachine::count_persistence(const StateEvidence& e, bool same_place, bool ready) {
  if (!ready) {
    streak_ = 0;
  } else {
    if (!(streak_ > 0 && same_place)) travel_ = 0.0;
    streak_ = streak_ > 0 && same_place ? streak_ + 1 : 1;
  }
  travel_ += e.motion.translation().norm();
}

TrackState TrackStateMachine::update(const StateEvidence& e) {
  const bool same = started_ && same_place_(last_ * e.motion, e.place);
  // A change of mind: the place left one the filter had converged at, or had concentrated on.
  if (started_ && (converged_once_ || concentrated_before_) && !same) {
    changed_ = true;
    travel_ = 0.0;
  }
  concentrated_before_ = e.concentrated;
  const bool plausible = e.inliers >= options_.min_inliers && !(e.coverage < options_.min_coverage);
  const bool ready = e.concentrated && plausible && e.searched && !e.rival_undecided && !e.holding;
  count_persistence(e, same, ready);
  last_ = e.place;
  started_ = true;
  if (e.implausible) {
    set(TrackState::kLost, StateReason::kImplausibleFit);
  } else if (e.recovery_lost) {
    set(TrackState::kLost, StateReason::kRecovery);
  } else if (holds_track()) {
    return hold(e, same);
  } else {
    return claim(e);
  }
  return state_;
}

TrackState TrackStateMachine::hold(const StateEvidence& e, bool same_place) {
  // Where the map covers too little of the scan at the track, nothing there can speak for or against it: that is
  // what the state says, whatever the belief does meanwhile.
  const bool unmapped =
      e.coverage < options_.min_coverage || (state_ == TrackState::kUnmapped && e.coverage < judged_coverage_);
  if (!same_place) {
    set(TrackState::kAmbiguous, StateReason::kChangeOfMind);
  } else if (unmapped) {
    set(TrackState::kUnmapped, StateReason::kMapCoversLittle);
  } else if (e.inliers < options_.min_inliers) {
    set(TrackState::kSearching, StateReason::kPoorFit);  // the scan no longer fits as a claim needs
  } else if (e.holding) {
    set(TrackState::kAmbiguous, StateReason::kChallenged);
  } else if (e.rival_proven) {
    set(TrackState::kAmbiguous, StateReason::kRivalProven);
  } else {
    set(TrackState::kConverged, StateReason::kProven);
  }
  return state_;
}

TrackState TrackStateMachine::claim(const StateEvidence& e) {
  const bool travelled = !changed_ || travel_ >= options_.travel_after_change_m;
  if (streak_ >= options_.min_updates && travelled) {
    converged_once_ = true;
    changed_ = false;
    set(TrackState::kConverged, StateReason::kProven);
  } else if (e.holding) {
    set(TrackState::kAmbiguous, StateReason::kChallenged);
  } else if (e.rival_proven) {
    set(TrackState::kAmbiguous, StateReason::kRivalProven);
  } else if (e.rival_undecided) {
    set(TrackState::kAmbiguous, StateReason::kRivalUndecided);
  } else if (e.second_weight >= options_.ambiguous_weight) {
    set(TrackState::kAmbiguous, StateReason::kSecondPlace);
  } else if (changed_ && e.concentrated) {
    set(TrackState::kAmbiguous, StateReason::kChangeOfMind);
  } else if (!e.concentrated) {
    set(TrackState::kSearching, StateReason::kSpread);
  } else if (!(e.inliers >= options_.min_inliers && !(e.coverage < options_.min_coverage))) {
    set(TrackState::kSearching, StateReason::kPoorFit);
  } else if (!e.searched) {
    set(TrackState::kSearching, StateReason::kSearchPending);
  } else {
    set(TrackState::kSearching, StateReason::kPersisting);
  }
  return state_;
}

}  // namespace tsdf_mcl
