#pragma once
// A jump needs proof. Once the filter has converged, its track is kept as a pose of its own, moved by the odometry
// and refined on each scan. When the belief's dominant hypothesis leaves it (a challenger: a look-alike room that
// explains a scan better because the robot entered space the map never observed), the published estimate stays on
// the track until the challenger has proven itself over `proof_travel_m` of travel (metres of odometry, not
// updates: the same view seen again is not new evidence), by paired evidence (scan_fit.hpp: both poses judged on
// the points observed under both). Proof comes sooner only when the track itself fails on points the map does
// cover (a kidnapping: implausible fit at the track for two updates). Evidence that goes the track's way instead
// disproves the challenger, and the filter puts particles back on the track (ParticleFilter).
#include <cstddef>

#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl {

struct TrackKeeperOptions {
  double proof_travel_m = 1.5;  // travel over which a challenger must explain the scans better; 0 = off
  // Accumulated paired evidence (nats, in the units the hypotheses' shares move by: hypothesis_weighting.hpp)
  // that proves a challenger once proof_travel_m has passed; as much the other way disproves it at any time.
  double proof_nats = 3.0;

  void validate() const;  // throws Error naming the parameter
};

class TrackKeeper {
 public:
  enum class Decision {
    kNone,     // no track (not converged since the last start): the belief decides alone
    kFollow,   // the dominant hypothesis continues the track: it is the estimate
    kHold,     // a challenger is unproven: the estimate stays on the track's continuation
    kAccept,   // the challenger is proven: it becomes the track
    kRestore,  // the challenger is disproven while the belief lost the track: put particles back on it
  };

  explicit TrackKeeper(const TrackKeeperOptions& options) : options_(options) {}

  // The track starts (again) at `pose`: the filter converged there.
  void start(const Pose& pose);
  void reset();  // no track (initialization, a wrong lock found out)
  bool active() const { return active_; }
  // Where the odometry carries the track: the last track pose times `motion`.
  Pose predict(const Pose& motion) const { return pose_ * motion; }

  // One filter update. `continuation`: predict(motion) refined on the scan; `top_continues`: the dominant
  // hypothesis lies at the continuation (ConvergenceOptions::max_jump_*); `top`: its pose; `evidence`: paired
  // evidence of the top over the continuation on this scan (nats, positive: the top explains it better);
  // `track_implausible`: the continuation's fit fails on points the map covers.
  Decision update(const Pose& motion, const Pose& continuation, bool top_continues, const Pose& top, double evidence,
                  bool track_implausible);

  const Pose& pose() const { return pose_; }
  bool challenged() const { return challenge_; }
  double challenge_evidence() const { return evidence_; }  // nats accumulated since the challenge began
  double challenge_travel() const { return travel_; }      // m since then

 private:
  void end_challenge();

  TrackKeeperOptions options_;
  bool active_ = false;
  Pose pose_ = Pose::Identity();
  bool challenge_ = false;
  double evidence_ = 0.0;
  double travel_ = 0.0;
  std::size_t implausible_ = 0;
};

}  // namespace tsdf_mcl
