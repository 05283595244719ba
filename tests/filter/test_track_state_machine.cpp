// TrackStateMachine (track_state_machine.hpp): when the filter enters `converged` and what alone ends it, update by
// update, with a reason for every state.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/track_state_machine.hpp"

namespace tsdf_mcl {
namespace {

Pose at(double x, double y) { return pose_from_xyz_rpy(x, y, 0.5, 0.0, 0.0, 0.0); }
Pose forward(double d) { return pose_from_xyz_rpy(d, 0.0, 0.0, 0.0, 0.0, 0.0); }

// A belief at `place` that meets every condition of the claim; tests spoil one at a time.
StateEvidence good(const Pose& place) {
  StateEvidence e;
  e.place = place;
  e.motion = Pose::Identity();
  e.concentrated = true;
  e.inliers = 0.9;
  e.coverage = 0.95;
  return e;
}

StateOptions options() {
  StateOptions o;
  o.min_updates = 3;
  o.travel_after_change_m = 5.0;
  return o;
}

// Drives `updates` updates moving `step` m forward each from `start`, each evidence made by `make` from the good one
// (update k, evidence). Returns the states.
template <typename Make>
std::vector<TrackState> drive(TrackStateMachine& m, const Pose& start, int updates, double step, Make make) {
  std::vector<TrackState> states;
  Pose p = start;
  for (int k = 0; k < updates; ++k) {
    StateEvidence e = good(p);
    if (k > 0) {
      p = p * forward(step);
      e = good(p);
      e.motion = forward(step);
    }
    make(k, e);
    states.push_back(m.update(e));
  }
  return states;
}

int first_converged(const std::vector<TrackState>& s) {
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s[k] == TrackState::kConverged) return static_cast<int>(k);
  }
  return -1;
}

std::size_t changes(const std::vector<TrackState>& s) {
  std::size_t n = 0;
  for (std::size_t k = 1; k < s.size(); ++k) n += s[k] != s[k - 1] ? 1 : 0;
  return n;
}

const auto as_is = [](int, StateEvidence&) {};

TEST(TrackStateMachine, ConvergesAfterMinUpdatesAtOnePlace) {
  TrackStateMachine m(options(), SamePlace{});
  const std::vector<TrackState> s = drive(m, at(0, 0), 10, 0.2, as_is);
  EXPECT_EQ(first_converged(s), 2);
  EXPECT_EQ(s[0], TrackState::kSearching);
  EXPECT_EQ(m.reason(), StateReason::kProven);
}

TEST(TrackStateMachine, NeverEnteredOnAPoorFitASpreadBeliefOrBeforeTheSearch) {
  const std::vector<std::pair<const char*, void (*)(int, StateEvidence&)>> spoilers = {
      {"inliers below min_inliers", [](int, StateEvidence& e) { e.inliers = 0.3; }},
      {"coverage below min_coverage", [](int, StateEvidence& e) { e.coverage = 0.4; }},
      {"not concentrated", [](int, StateEvidence& e) { e.concentrated = false; }},
      {"a rival undecided", [](int, StateEvidence& e) { e.rival_undecided = true; }},
      {"a challenger weighed", [](int, StateEvidence& e) { e.holding = true; }},
      {"the background search pending", [](int, StateEvidence& e) { e.searched = false; }},
  };
  for (const auto& [what, spoil] : spoilers) {
    TrackStateMachine m(options(), SamePlace{});
    EXPECT_EQ(first_converged(drive(m, at(0, 0), 20, 0.2, spoil)), -1) << what;
  }
  // The coverage at the line itself enters: the comparison's direction matters.
  TrackStateMachine edge(options(), SamePlace{});
  EXPECT_EQ(first_converged(drive(edge, at(0, 0), 10, 0.2, [](int, StateEvidence& e) { e.coverage = 0.5; })), 2);
}

TEST(TrackStateMachine, ASpreadAPoorScanOrANewRivalDoNotEndIt) {
  // Once converged, the noise of single updates must not toggle the flag: a spread (the cloud widening in a turn), a
  // scan that fits worse for an update but still as a claim needs, a newly found look-alike the ledger has not
  // decided.
  TrackStateMachine m(options(), SamePlace{});
  const std::vector<TrackState> s = drive(m, at(0, 0), 40, 0.2, [](int k, StateEvidence& e) {
    if (k >= 5) e.concentrated = k % 3 != 0;
    if (k >= 5 && k % 4 == 0) e.inliers = 0.55;
    if (k >= 5 && k % 5 == 0) e.rival_undecided = true;
    if (k >= 5 && k % 7 == 0) e.second_weight = 0.3;
  });
  EXPECT_EQ(first_converged(s), 2);
  EXPECT_EQ(changes(s), 1u) << "searching -> converged, and nothing after";
}

TEST(TrackStateMachine, LeftOnlyOnEvidence) {
  struct Case {
    const char* what;
    void (*spoil)(int, StateEvidence&);
    TrackState state;
    StateReason reason;
  };
  const std::vector<Case> cases = {
      {"implausible fit", [](int, StateEvidence& e) { e.implausible = true; }, TrackState::kLost,
       StateReason::kImplausibleFit},
      {"recovery", [](int, StateEvidence& e) { e.recovery_lost = true; }, TrackState::kLost, StateReason::kRecovery},
      {"a rival proven", [](int, StateEvidence& e) { e.rival_proven = true; }, TrackState::kAmbiguous,
       StateReason::kRivalProven},
      {"the belief moved to a challenger", [](int, StateEvidence& e) { e.holding = true; }, TrackState::kAmbiguous,
       StateReason::kChallenged},
      {"the map covers little", [](int, StateEvidence& e) { e.coverage = 0.4; }, TrackState::kUnmapped,
       StateReason::kMapCoversLittle},
      {"a fit under what a claim needs", [](int, StateEvidence& e) { e.inliers = 0.45; }, TrackState::kSearching,
       StateReason::kPoorFit},
  };
  for (const Case& c : cases) {
    TrackStateMachine m(options(), SamePlace{});
    const std::vector<TrackState> s = drive(m, at(0, 0), 8, 0.2, [&](int k, StateEvidence& e) {
      if (k == 6) c.spoil(k, e);
    });
    EXPECT_EQ(s[5], TrackState::kConverged) << c.what;
    EXPECT_EQ(s[6], c.state) << c.what;
  }
  for (const Case& c : cases) {
    TrackStateMachine m(options(), SamePlace{});
    drive(m, at(0, 0), 7, 0.2, [&](int k, StateEvidence& e) {
      if (k == 6) c.spoil(k, e);
    });
    EXPECT_EQ(m.reason(), c.reason) << c.what;
  }
}

TEST(TrackStateMachine, UnmappedHasHysteresis) {
  // Out of converged below min_coverage; back only where the map covers most of the scan (0.75): a coverage that
  // wanders around min_coverage does not toggle the state.
  TrackStateMachine m(options(), SamePlace{}, 0.75);
  const std::vector<double> coverage = {0.9, 0.9, 0.9, 0.9, 0.55, 0.45, 0.55, 0.6, 0.45, 0.7, 0.8, 0.6, 0.55, 0.65};
  const std::vector<TrackState> s =
      drive(m, at(0, 0), static_cast<int>(coverage.size()), 0.2,
            [&](int k, StateEvidence& e) { e.coverage = coverage[static_cast<std::size_t>(k)]; });
  EXPECT_EQ(s[3], TrackState::kConverged);
  EXPECT_EQ(s[4], TrackState::kConverged) << "0.55 is above min_coverage";
  EXPECT_EQ(s[5], TrackState::kUnmapped);
  for (std::size_t k = 6; k <= 9; ++k) EXPECT_EQ(s[k], TrackState::kUnmapped) << k;
  EXPECT_EQ(s[10], TrackState::kConverged) << "back where the map covers most of the scan";
  for (std::size_t k = 11; k < s.size(); ++k) EXPECT_EQ(s[k], TrackState::kConverged) << k;
}

// The belief concentrated on one place (an operator's wrong initial pose) that never fitted well enough, then the
// background search moved it to a look-alike that fits plausibly: that place must hold over travel first.
TEST(TrackStateMachine, AChangeOfMindFromAConcentratedBeliefNeedsTravel) {
  TrackStateMachine m(options(), SamePlace{});
  EXPECT_EQ(first_converged(drive(m, at(0, 0), 5, 0.2, [](int, StateEvidence& e) { e.inliers = 0.4; })), -1);
  // 0.2 m per update: 5 m of travel take 25 updates.
  const std::vector<TrackState> s = drive(m, at(20, 5), 60, 0.2, as_is);
  EXPECT_GE(first_converged(s), 25);
  EXPECT_LE(first_converged(s), 27);
  EXPECT_EQ(s[10], TrackState::kAmbiguous);
  EXPECT_EQ(changes(s), 1u);
}

TEST(TrackStateMachine, AJumpAfterConvergenceNeedsTravel) {
  TrackStateMachine m(options(), SamePlace{});
  ASSERT_EQ(first_converged(drive(m, at(0, 0), 5, 0.2, as_is)), 2);
  const std::vector<TrackState> s = drive(m, at(20, 5), 60, 0.2, as_is);
  EXPECT_EQ(s[0], TrackState::kAmbiguous);
  EXPECT_EQ(m.converged_once(), true);
  EXPECT_GE(first_converged(s), 25);
}

TEST(TrackStateMachine, AWrongLockFoundOutNeedsTravel) {
  TrackStateMachine m(options(), SamePlace{});
  m.restart_after_wrong_lock();
  EXPECT_GE(first_converged(drive(m, at(3, 3), 60, 0.2, as_is)), 25);
  m.reset();
  EXPECT_EQ(first_converged(drive(m, at(3, 3), 60, 0.2, as_is)), 2) << "reset() forgets the doubt";
}

TEST(TrackStateMachine, EveryStateAndReasonHasAName) {
  for (std::size_t s = 0; s < kTrackStates; ++s) {
    const auto state = static_cast<TrackState>(s);
    ASSERT_TRUE(parse_track_state(to_string(state)));
    EXPECT_EQ(*parse_track_state(to_string(state)), state);
  }
  EXPECT_FALSE(parse_track_state("tracking"));
  for (std::size_t r = 0; r < kStateReasons; ++r)
    EXPECT_GT(std::string(to_string(static_cast<StateReason>(r))).size(), 5u);
}

TEST(TrackStateMachine, OptionsSayWhatIsWrong) {
  StateOptions o = options();
  o.min_updates = 0;
  EXPECT_THROW(TrackStateMachine(o, SamePlace{}), Error);
  o = options();
  o.min_inliers = 1.5;
  EXPECT_THROW(TrackStateMachine(o, SamePlace{}), Error);
  EXPECT_THROW(TrackStateMachine(options(), SamePlace{-1.0, 0.3}), Error);
}

}  // namespace
}  // namespace tsdf_mcl
