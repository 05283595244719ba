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
// A look-alike the scans prove better than the track (its evidence summed to refute_nats the other way since it was
// found and within the last proof_window_m of travel, while the map covers most of the track's scan) is named by
// proven(). Where the belief lost its particles there, an equal share is out of reach for it (from 2e-6, tens of
// scans of a view that tells the places apart): the filter puts particles back at it (where the belief holds less than
// half of it) with the share those scans give it, the belief a set that had kept particles there would hold; until the
// track first converges, any look-alike kept over proof_window_m of travel (kept(), proven or not) is put back so. When
// the track then moves to a look-alike, the place it left starts with the look-alike's evidence turned round: the scans
// that proved one refuted the other; the other look-alikes' sums start over whenever the track jumps (evidence against
// one track says nothing against another).
#include <Eigen/Core>
#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <utility>
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
  // A look-alike is proven better than the track (proven()) by refute_nats within this much travel (m of odometry):
  // a view that tells the places apart moves the evidence by tenths of a nat a scan, while the sum since a place was
  // found also gathers a drift of thousandths a scan, which reached 3 nats against the right storey after 540 scans
  // in the two-storey VLP-16 ground-3 run.
  double proof_window_m = 2.0;
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
  // A kept look-alike as the scans since it was found judge it against the track.
  struct Standing {
    Pose place;                 // its refined world pose on this scan
    double evidence = 0.0;      // summed for the track since it was found (proven: -refute_nats or less)
    double travelled = 0.0;     // m of odometry that sum spans
    double odds_share() const;  // the share of {track, place} the evidence gives the place: 1 / (1 + e^evidence)
  };
  using Judge =
      std::function<Verdict(const Pose& track, const Pose& place, const std::vector<Eigen::Vector3f>& points)>;

  LookAlikeMemory(const TsdfMap& map, const LookAlikeOptions& options, Judge judge, double max_jump_m,
                  double max_jump_rad);

  void reset();
  // One filter update. `track`: the dominant hypothesis's refined pose; `motion`: the odometry since the last update;
  // `others`: other places the belief holds (refined poses); `points`: the scan (sensor frame). Returns the
  // look-alikes kept after this scan. `track_mapped`: the map covers most of the track's scan; where it does not
  // (the frontier of unmapped space fits worse than a mapped look-alike wherever the robot is) no place is proven.
  std::size_t update(const Pose& track, const Pose& motion, const std::vector<Pose>& others,
                     const std::vector<Eigen::Vector3f>& points, bool track_mapped);

  bool enabled() const { return options_.refute_nats > 0.0; }
  // World poses of the kept look-alikes at the last update.
  std::vector<Pose> places() const;
  // The kept look-alike the scans prove better than the track (the best-proven one) at this update, if any: on every
  // update while its evidence holds, whether or not the belief already followed it (the filter judges that).
  const std::optional<Standing>& proven() const { return proven_; }
  // Every kept look-alike at the last update, proven or not.
  std::vector<Standing> kept() const;

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
  double travel_ = 0.0;            // m of odometry since the reset
  // Kept look-alikes and refuted places, as transforms from the track: place = relative * track.
  struct LookAlike {
    Pose relative;
    double evidence = 0.0;  // for the track, summed over the scans since it was found
    // The scans within the last proof_window_m of travel: (travel_ when taken, evidence).
    std::deque<std::pair<double, double>> recent;
    double recent_evidence() const;
    double found_at = 0.0;  // travel_ when found (or when its sum started over)
  };
  std::vector<LookAlike> look_alikes_;
  std::vector<Pose> refuted_;
  std::optional<Standing> proven_;
};

}  // namespace tsdf_mcl
