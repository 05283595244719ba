#pragma once
// Places the belief's shares no longer speak for. A hypothesis's share says what the scans said about its place only
// while the belief held particles there: a look-alike that resampling dropped (a global search that lost one storey
// of a building whose storeys repeat one plan) and that the background search found again later comes back with a
// negligible share, which an equal fit never raises, and `converged` was claimed on the wrong storey for 216 scans
// (docs/filter.md, "Two storeys of one plan"). This memory judges places by evidence, not by shares:
//   - a look-alike: a place elsewhere (another hypothesis, or the best-fitting particle outside them) that explains
//     about as much of the scan as the track (within explain_margin, as ConvergenceOptions::competitor_margin: a place
//     whose points fly out of the map shares no evidence with the track, and so none against it) and that the scan
//     does not refute: the paired evidence of the track over it (scan_fit.hpp, in the units the hypotheses' shares
//     move by) is below refute_nats;
//   - it is kept as the rigid transform from the track to it, followed with the track and refined on each scan
//     whether or not the belief still holds particles there, its evidence summed scan by scan until it reaches
//     refute_nats, or until a scan it explains clearly less of; then it is refuted;
//   - a refuted place stays refuted (as its transform, followed with the track) when the search finds it again, until
//     a scan alone favours it by refute_nats: found again it starts over with a tiny share, and nothing measured since
//     tells it from a place found for the first time.
// While a look-alike is kept, `converged` waits (ConvergenceMonitor::update's `look_alike`).
#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

struct LookAlikeOptions {
  // Paired evidence (nats) for the track that refutes a look-alike, as the track keeper's proof_nats proves a
  // challenger. 0 = off: no memory, `converged` judges the hypotheses' shares alone.
  double refute_nats = 3.0;
  // A look-alike explains at least the track's share of the scan's points (inliers over all) less this.
  double explain_margin = 0.1;
  std::size_t max_places = 8;    // look-alikes kept at once
  std::size_t max_refuted = 64;  // refuted places remembered (the oldest forgotten first)

  void validate() const;  // throws Error naming the parameter
};

class LookAlikeMemory {
 public:
  // What a scan says of the track against a place.
  struct Verdict {
    double evidence = 0.0;  // paired evidence (nats, in the units the hypotheses' shares move by; + for the track)
    double track_explained = 0.0;  // share of the scan's points each explains (inliers over all points)
    double place_explained = 0.0;
  };
  using Judge =
      std::function<Verdict(const Pose& track, const Pose& place, const std::vector<Eigen::Vector3f>& points)>;

  LookAlikeMemory(const TsdfMap& map, const LookAlikeOptions& options, Judge judge, double max_jump_m,
                  double max_jump_rad);

  void reset();
  // One filter update. `track`: the dominant hypothesis's refined pose; `motion`: the odometry since the last update;
  // `others`: other places the belief holds (refined poses); `points`: the scan (sensor frame). Returns the
  // look-alikes kept after this scan.
  std::size_t update(const Pose& track, const Pose& motion, const std::vector<Pose>& others,
                     const std::vector<Eigen::Vector3f>& points);

  bool enabled() const { return options_.refute_nats > 0.0; }
  // World poses of the kept look-alikes at the last update.
  std::vector<Pose> places() const;

 private:
  bool near(const Pose& a, const Pose& b) const;
  void refute(const Pose& relative);

  const TsdfMap& map_;
  LookAlikeOptions options_;
  Judge judge_;
  double max_jump_m_;
  double max_jump_rad_;
  bool started_ = false;
  Pose track_ = Pose::Identity();  // the track at the last update
  // Kept look-alikes and refuted places, as transforms from the track: place = relative * track.
  struct LookAlike {
    Pose relative;
    double evidence = 0.0;  // for the track, summed over the scans since it was found
  };
  std::vector<LookAlike> look_alikes_;
  std::vector<Pose> refuted_;
};

}  // namespace tsdf_mcl
