#include "tsdf_mcl/filter/track_keeper.hpp"

#include <cmath>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/track_state.hpp"

namespace tsdf_mcl {

const char* to_string(TrackState state) {
  switch (state) {
    case TrackState::kSearching:
      return "searching";
    case TrackState::kTracking:
      return "tracking";
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
  for (const TrackState s : {TrackState::kSearching, TrackState::kTracking, TrackState::kAmbiguous,
                             TrackState::kConverged, TrackState::kUnmapped, TrackState::kLost}) {
    if (name == to_string(s)) return s;
  }
  return std::nullopt;
}

void TrackKeeperOptions::validate() const {
  if (!(proof_travel_m >= 0.0 && std::isfinite(proof_travel_m)))
    throw Error("track_proof_travel must be finite and >= 0 (m)");
  if (!(proof_nats > 0.0 && std::isfinite(proof_nats))) throw Error("track_proof_nats must be finite and > 0");
}

void TrackKeeper::start(const Pose& pose) {
  active_ = true;
  pose_ = pose;
  end_challenge();
}

void TrackKeeper::reset() {
  active_ = false;
  end_challenge();
}

void TrackKeeper::end_challenge() {
  challenge_ = false;
  evidence_ = 0.0;
  travel_ = 0.0;
  implausible_ = 0;
}

TrackKeeper::Decision TrackKeeper::update(const Pose& motion, const Pose& continuation, bool top_continues,
                                          const Pose& top, double evidence, bool track_implausible) {
  if (!active_) return Decision::kNone;
  if (top_continues || options_.proof_travel_m <= 0.0) {
    // The belief follows the track, or proof is off and every jump is taken at once.
    pose_ = top;
    end_challenge();
    return top_continues ? Decision::kFollow : Decision::kAccept;
  }
  // The dominant hypothesis is elsewhere: a challenge, begun now or going on.
  if (challenge_) travel_ += motion.translation().norm();
  challenge_ = true;
  evidence_ += evidence;
  implausible_ = track_implausible ? implausible_ + 1 : 0;
  const bool proven = implausible_ >= 2 || (travel_ >= options_.proof_travel_m && evidence_ >= options_.proof_nats);
  if (proven) {
    pose_ = top;
    end_challenge();
    return Decision::kAccept;
  }
  pose_ = continuation;
  if (evidence_ <= -options_.proof_nats) {
    end_challenge();
    return Decision::kRestore;
  }
  return Decision::kHold;
}

}  // namespace tsdf_mcl
