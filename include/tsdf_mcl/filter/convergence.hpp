#pragma once
// When the filter says `converged`. A robot drives on that word, so it must mean "the track is right", and a
// dominant mode is not enough: in a building of look-alike rooms the particle set can collapse onto the wrong
// room within a few scans. Converged requires all of:
//   - concentrated: the dominant hypothesis holds converged_weight of the belief (after the between-hypothesis
//     tempering, so a look-alike that fits as well keeps its share) and is compact (PoseEstimateOptions);
//   - plausible: the scan fits the map there as a correct track's does, measured absolutely (inlier ratio),
//     not against a running average that may have started at a wrong lock;
//   - unchallenged: no other hypothesis with a credible share (competitor_min_weight) explains the scan
//     nearly as well, however far the dominant one leads above that share; nor is a look-alike kept, whatever its
//     share (look_alikes.hpp: a place elsewhere that the scans since it was found have not refuted);
//   - persistent: all of it held for min_updates consecutive filter updates at one place (the dominant
//     hypothesis moved as the odometry says), so one lucky scan does not decide; counted only once the
//     background search (challengers, particle_filter.hpp) has had its say, so that a lone wrong lock is
//     questioned before it is believed;
//   - after a change of mind, proven by travel: once the filter has converged or concentrated on one place, a
//     dominant hypothesis that jumps elsewhere means the filter was wrong before or is wrong now. The new place must
//     then stay dominant over travel_after_jump_m of motion (new views of the building) before it is called converged:
//     the evidence that moved the belief may come from one badly mapped corner (a drone under a ceiling that the ground
//     robot that built the map saw only at grazing angles), and the same corner seen again is not new evidence. The
//     same holds after a wrong lock was found out (an implausible fit made the filter search again): the search that
//     chose the wrong place once may choose a look-alike again (an operator's initial pose that was wrong, or a
//     kidnapping, sends the search through the whole map), so its next place too must hold over travel_after_jump_m.
// Recovery that considers the track lost overrides all of it.
#include <cstddef>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"

namespace tsdf_mcl {

struct ConvergenceOptions {
  // The dominant hypothesis's inlier ratio (scan_fit.hpp) must be at least this. Correct tracks measured on
  // real and simulated data stay above it (docs/filter.md); wrong locks mostly fall below.
  double min_inlier_ratio = 0.5;
  // ... and the map must cover at least this share of the scan there (Hypothesis::coverage): an inlier ratio
  // over a few observed points proves nothing. Below it the filter tracks through unmapped space (TrackState).
  double min_coverage = 0.5;
  std::size_t min_updates = 3;
  // A hypothesis other than the dominant one, holding at least competitor_min_weight of the belief, further
  // than max_jump from it and with an inlier ratio within competitor_margin of the dominant one's, is a
  // competitor. Lighter hypotheses stay alive (ParticleFilter keeps them down to hypothesis_min_weight) to come
  // back if the views turn their way, but the evidence has spoken against them.
  double competitor_margin = 0.1;
  double competitor_min_weight = 1e-3;
  // Between two updates the dominant hypothesis may differ from where the odometry moves the last one by this
  // much and still count as the same place.
  double max_jump_m = 0.5;
  double max_jump_rad = 0.35;
  // Whether two poses are one place: within max_jump_m and max_jump_rad of each other.
  bool same_place(const Pose& a, const Pose& b) const;
  // Travel (odometry translation, m) the dominant hypothesis must hold after a jump away from a converged track
  // or after a wrong lock was found out.
  double travel_after_jump_m = 5.0;

  void validate() const;  // throws Error naming the parameter
};

class ConvergenceMonitor {
 public:
  explicit ConvergenceMonitor(const ConvergenceOptions& options);

  // One filter update: `concentrated` = PoseEstimator's test on the dominant hypothesis; `motion` = the
  // odometry since the last update (identity without odometry); `lost` = recovery considers the track lost.
  // `searched`: challengers have been weighed since the belief concentrated (always true without a background
  // search). `look_alike`: a place the scans have not told from the track is kept (look_alikes.hpp).
  bool update(const PoseEstimate& estimate, bool concentrated, const Pose& motion, bool lost, bool searched,
              bool look_alike = false);
  void reset();
  // reset(), and the next place must hold over travel_after_jump_m: the filter just found out it was wrong.
  void restart_after_wrong_lock();
  std::size_t streak() const { return streak_; }  // consecutive updates concentrated and plausible at one place
  // Whether a hypothesis of `estimate` competes with the dominant one (see competitor_margin).
  bool challenged(const PoseEstimate& estimate) const;

 private:
  ConvergenceOptions options_;
  std::size_t streak_ = 0;
  Pose last_ = Pose::Identity();
  bool converged_once_ = false;       // since reset(): a jump after it needs travel_after_jump_m
  bool concentrated_before_ = false;  // the last update's belief was concentrated: a jump from it needs it too
  bool jumped_ = false;  // a jump after converged_once_ or a wrong lock found out, not yet proven by travel
  double travel_ = 0.0;  // m of odometry since the streak started
};

}  // namespace tsdf_mcl
