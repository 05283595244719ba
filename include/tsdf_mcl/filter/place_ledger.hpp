#pragma once
// The one sequential test between places (Wald's SPRT). The filter keeps a *track*: the place its estimate reports.
// Every other place that explains about as much of the scan (a rival: another place of the belief, the best-fitting
// particles elsewhere, a challenger the belief moved to, the place a track left) gets an entry here, kept as the rigid
// transform from the track to it and followed with the track whether or not the belief still holds particles there.
// Each scan adds the paired evidence of the track over the rival (scan_fit.hpp: on the points observed at both, in the
// units the places' shares move by) to the entry's log-likelihood ratio. One pair of thresholds decides:
//   - refuted: the ratio reaches +decide_nats for the track (or the rival explains clearly less of the scan). A refuted
//     place stays refuted when the search finds it again, until one scan alone favours it by decide_nats;
//   - proven: the ratio reaches -decide_nats against the track, summed both since the rival was found and over the
//     last `window_m` of travel where the map judged the track, once the entry spans window_m of travel (a view seen
//     from one spot, or a drift of thousandths a scan over hundreds of scans, proves nothing);
//   - undecided in between.
// Evidence against the track counts only where the map covers most of the track's scan: at the frontier of space the
// map never observed, the surfaces the mapping run saw once fit worse than a mapped look-alike wherever the robot is.
// What was counted there stays counted when the track leaves the map (a robot carried off into unmapped space).
//
// The filter says where the track is on each scan: the belief's dominant place where it continues the track or where
// the track still follows the belief (before the filter first converges), else the track's own continuation, refined
// onto the map, with the dominant place as the challenger. A challenger is taken once proven, or at once when the
// track fails on its own for two updates where the map covers its scan (a kidnapping). When the track moves, the place
// it left becomes a rival with the evidence turned round (the scans that proved one refuted the other), and the other
// rivals start over (evidence against one track says nothing against another).
#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/same_place.hpp"

namespace tsdf_mcl {

struct LedgerOptions {
  // |log-likelihood ratio| (nats) at which a pair is decided (both thresholds of the test). 0 = off: no rival is
  // followed and a challenger is taken at once.
  double decide_nats = 3.0;
  double window_m = 2.0;  // m of travel a proof spans (see above)
  // A rival explains at least the track's share of the scan's points (inliers over all) less this; one that explains
  // less is refuted on the spot.
  double explain_margin = 0.1;
  std::size_t max_rivals = 8;    // rivals followed at once
  std::size_t max_refuted = 64;  // refuted places remembered (the oldest forgotten first)

  void validate() const;  // throws Error naming the parameter
};

class PlaceLedger {
 public:
  // What one scan says of the track against a place.
  struct Verdict {
    double evidence = 0.0;         // nats, positive: for the track
    double track_explained = 0.0;  // share of the scan's points each explains (inliers over all points)
    double place_explained = 0.0;
  };
  using Judge = std::function<Verdict(const Pose& track, const Pose& place)>;
  using Refine = std::function<Pose(const Pose& start)>;

  // A rival as the scans since it was found judge it against the track.
  struct Standing {
    Pose place;                 // its refined world pose on this scan
    double evidence = 0.0;      // log-likelihood ratio for the track since it was found
    double travelled = 0.0;     // m of odometry the entry spans
    bool proven = false;        // decided against the track
    double odds_share() const;  // the share of {track, place} the ratio gives the place: 1 / (1 + e^evidence)
  };

  struct Input {
    Pose motion = Pose::Identity();  // odometry since the last update
    Pose track;                      // the track's pose on this scan (see above)
    std::optional<Pose> challenger;  // the dominant place, where it lies elsewhere and the track holds
    std::vector<Pose> others;        // other places worth judging (refined)
    bool track_mapped = true;        // the map covers most of the scan at the track
    bool track_implausible = false;  // the track's fit fails where the map covers its scan
  };
  struct Outcome {
    Pose track;            // the place the estimate reports
    bool holding = false;  // the challenger is not decided: the track holds
    bool moved = false;    // the track left the place it held (followed the belief, or a challenger taken)
    bool challenger_taken = false;
    double challenge = 0.0;           // while holding: the ratio for the track against the challenger
    double challenge_travel = 0.0;    // m it spans
    std::vector<Standing> rivals;     // followed after this update, but the challenger
    std::optional<Standing> proven;   // the best-proven rival that is not the challenger, if any (also in rivals)
    bool challenger_refuted = false;  // the challenger was refuted on this update
  };

  PlaceLedger(const LedgerOptions& options, const SamePlace& same_place, Judge judge, Refine refine);

  void reset();
  bool enabled() const { return options_.decide_nats > 0.0; }
  bool started() const { return started_; }
  const Pose& track() const { return track_; }
  Pose predict(const Pose& motion) const { return track_ * motion; }
  const LedgerOptions& options() const { return options_; }
  Outcome update(const Input& in);

 private:
  struct Rival {
    Pose relative;                                 // place = relative * track
    double evidence = 0.0;                         // for the track since it was found
    std::deque<std::pair<double, double>> recent;  // (judged_travel_ when taken, evidence) over the last window_m
    double found_at = 0.0;                         // travel_ when found (or when its ratio started over)
    double window() const;
  };
  Standing standing(const Rival& r) const;
  bool proven(const Rival& r) const;
  bool plausible(const Verdict& v) const;
  std::vector<Verdict> judge_all(const std::vector<Pose>& places) const;
  double counted(double evidence, bool track_mapped) const;
  void refute(const Pose& relative);
  // The rivals and refuted places kept where the odometry carries them, relative to a track that moved.
  void rebase(const Pose& predicted, const Pose& track);
  // The followed rivals' ratios after this scan; `inherited`: the ratio of the one the track moved onto, turned round.
  void follow_rivals(const std::vector<Pose>& places, const std::vector<Verdict>& verdicts, std::size_t followed,
                     bool moved, bool track_mapped, double& inherited);
  void admit(const std::vector<Pose>& places, const std::vector<Verdict>& verdicts, std::size_t followed,
             std::optional<std::size_t> left, double inherited, bool track_mapped);
  // The challenger's turn while the track holds: taken, refuted or still holding.
  void challenge(const Input& in, const Pose& continuation, Outcome& out);
  std::optional<std::size_t> rival_at(const Pose& place) const;

  LedgerOptions options_;
  SamePlace same_place_;
  Judge judge_;
  Refine refine_;
  bool started_ = false;
  Pose track_ = Pose::Identity();
  double travel_ = 0.0;         // m of odometry since the reset
  double judged_travel_ = 0.0;  // of which the map covered most of the track's scan
  std::size_t failing_ = 0;     // updates in a row the track failed on its own while holding
  std::vector<Rival> rivals_;
  std::vector<Pose> refuted_;  // relative to the track
};

}  // namespace tsdf_mcl
