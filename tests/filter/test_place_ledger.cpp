// PlaceLedger (place_ledger.hpp): one sequential test between the track and each rival. A rival the evidence does not
// refute is followed, whatever the belief holds there, until the scans refute or prove it; a refuted place found again
// stays refuted; a challenger is held off until proven.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "filter_test_runs.hpp"
#include "filter_test_scene.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/place_ledger.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"

namespace tsdf_mcl {
namespace {

using test::Box;

constexpr float kInlier = 0.2f;

// The twin-wing building's half turn about (12, 4): every view from one wing is the view from the other.
Pose half_turn(const Pose& p) { return pose_from_xyz_rpy(24.0, 8.0, 0.0, 0.0, 0.0, M_PI) * p; }

struct Walk {
  std::vector<Pose> truth;
  std::vector<std::vector<Eigen::Vector3f>> points;
  Pose motion(std::size_t i) const { return i == 0 ? Pose::Identity() : truth[i - 1].inverse() * truth[i]; }
};

// From room A's middle through its door into the corridor, past the niche whose cabinet tells the wings apart (in
// view from x ~9.7 to 12.5) and on to x 16.5, 0.3 m a scan.
Walk walk(const std::vector<Box>& boxes) {
  Walk w;
  w.truth = test::route_through({{3.0, 3.0}, {5.0, 4.0}, {16.5, 4.0}});
  w.points = test::scan_route(boxes, w.truth, 5).points;
  return w;
}

TsdfMap twin_map(bool with_feature) {
  return test::make_box_map(test::twin_wing_boxes(with_feature), Eigen::Vector3f(-0.2f, -0.2f, -0.2f),
                            Eigen::Vector3f(24.2f, 8.2f, 2.8f));
}

// The filter's judge (filter_decision.cpp: judge_places): paired evidence on the points both poses observe, clear of
// the frontier, a scan worth 16 points; the share of the scan each pose explains.
PlaceLedger::Verdict judge(const TsdfMap& map, const Pose& a, const Pose& b,
                           const std::vector<Eigen::Vector3f>& points) {
  EndpointModel model;
  const double dead_band = 0.5 * kInlier * kInlier / (model.sigma_hit * model.sigma_hit);
  const PointEvidence at_a = point_evidence(map, model, a, points, kInlier, map.truncation());
  const PointEvidence at_b = point_evidence(map, model, b, points, kInlier, map.truncation());
  const PairedEvidence e = paired_evidence(at_a, at_b, dead_band);
  return {16.0 * e.sum / static_cast<double>(points.size()), at_a.fit.absolute_inlier_ratio(),
          at_b.fit.absolute_inlier_ratio()};
}

// A ledger judging on the map with the scan of the step running; `per_scan`, if set, replaces the evidence.
struct Judged {
  const TsdfMap& map;
  const std::vector<Eigen::Vector3f>* scan = nullptr;
  const double* per_scan = nullptr;
  PlaceLedger ledger;
  explicit Judged(const TsdfMap& m, const LedgerOptions& options = {})
      : map(m),
        ledger(
            options, SamePlace{},
            [this](const Pose& a, const Pose& b) {
              PlaceLedger::Verdict v = judge(map, a, b, *scan);
              if (per_scan) v.evidence = *per_scan;
              return v;
            },
            [this](const Pose& start) { return refine_pose(map, start, *scan); }) {}
  PlaceLedger::Outcome step(const Walk& w, std::size_t i, const Pose& track, std::vector<Pose> others = {},
                            bool mapped = true) {
    scan = &w.points[i];
    PlaceLedger::Input in;
    in.motion = w.motion(i);
    in.track = track;
    in.others = std::move(others);
    in.track_mapped = mapped;
    return ledger.update(in);
  }
};

// The evidence of a scan for the truth over its image (the cabinet in view: clearly positive).
double told(const TsdfMap& map, const Walk& w, std::size_t i) {
  return judge(map, w.truth[i], half_turn(w.truth[i]), w.points[i]).evidence;
}

TEST(PlaceLedger, ARivalIsFollowedUntilTheScansRefuteIt) {
  const TsdfMap map = twin_map(true);
  const Walk w = walk(test::twin_wing_boxes(true));
  Judged j(map);
  double evidence = 0.0;  // for the truth over the image, scan by scan
  double walked = 0.0;    // m of odometry since the image was found
  bool refuted = false;
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    evidence += told(map, w, i);
    if (i > 0) walked += w.motion(i).translation().norm();
    // The belief holds the image only for the first scan: the ledger follows it from there on its own.
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const PlaceLedger::Outcome out = j.step(w, i, w.truth[i], others);
    if (evidence < 1.0) {
      ASSERT_EQ(out.rivals.size(), 1u) << "scan " << i << ": the wings look alike so far";
      // Followed where the odometry carries it (the image of the track), the travel since it was found, and a ratio
      // as even as the scans so far: about half of the pair's belief.
      EXPECT_LT(test::translation_error(out.rivals.front().place, half_turn(w.truth[i])), 0.2) << "scan " << i;
      EXPECT_NEAR(out.rivals.front().travelled, walked, 1e-9) << "scan " << i;
      EXPECT_GT(out.rivals.front().odds_share(), 0.2) << "scan " << i;
      EXPECT_FALSE(out.rivals.front().proven) << "scan " << i;
    }
    if (evidence > 2.0 * LedgerOptions{}.decide_nats) {
      EXPECT_TRUE(out.rivals.empty()) << "scan " << i << ": the cabinet was in view";
    }
    refuted = refuted || out.rivals.empty();
  }
  EXPECT_TRUE(refuted) << "the walk never refuted the image (evidence " << evidence << ")";
}

// The image offered again at the end of the walk, where the scan alone does not tell the wings apart (a challenger
// that found it again): refuted at the cabinet, it stays refuted; never judged before, it is followed.
std::size_t offer_again(bool offered_at_start) {
  const TsdfMap map = twin_map(true);
  const Walk w = walk(test::twin_wing_boxes(true));
  Judged j(map);
  const std::size_t last = w.truth.size() - 1;
  EXPECT_LT(std::abs(told(map, w, last)), 0.1) << "the last scan alone should not tell the wings apart";
  for (std::size_t i = 0; i < last; ++i) {
    std::vector<Pose> others;
    if (i == 0 && offered_at_start) others.push_back(half_turn(w.truth[0]));
    j.step(w, i, w.truth[i], others);
  }
  return j.step(w, last, w.truth[last], {half_turn(w.truth[last])}).rivals.size();
}

TEST(PlaceLedger, RefutedStaysRefutedWhenFoundAgain) { EXPECT_EQ(offer_again(true), 0u); }

TEST(PlaceLedger, FoundForTheFirstTimeIsFollowed) { EXPECT_EQ(offer_again(false), 1u); }

TEST(PlaceLedger, RivalsFollowTheTrackWhenItMoves) {
  // The track moves to the image (before the first convergence it follows the belief): the rivals stay where the
  // odometry carries them, and the place it left, as good on every scan, is the rival now.
  const TsdfMap map = twin_map(false);
  const Walk w = walk(test::twin_wing_boxes(false));
  Judged j(map);
  for (std::size_t i = 0; i < 10; ++i) {
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const bool moved = i >= 6;
    const PlaceLedger::Outcome out = j.step(w, i, moved ? half_turn(w.truth[i]) : w.truth[i], others);
    ASSERT_EQ(out.rivals.size(), 1u) << "scan " << i;
    EXPECT_EQ(out.moved, i == 6) << "scan " << i;
    EXPECT_LT(test::translation_error(out.rivals.front().place, moved ? w.truth[i] : half_turn(w.truth[i])), 0.2)
        << "scan " << i;
  }
}

// The track on the wrong wing, the truth offered once at the start: when the cabinet comes into view the scans prove
// the truth better, with the share their ratio gives it, on each scan until the track moves there; the wing it left
// carries the proof against it and stays refuted. Without the map judging the track's scan nothing is proven.
struct ProofWalk {
  std::size_t proofs = 0;            // scans on which the truth was proven better
  std::size_t scans_from_first = 0;  // scans from the first proof on
  double proven_at_x = 0.0;          // m: where the truth was at the first proof
  double share = 0.0;                // its odds share
  double place_error = 1e9;          // m, from the truth
  std::size_t rivals_after_move = 99;
  std::size_t rivals_when_offered_again = 99;
};

ProofWalk prove(bool track_mapped, bool follows) {
  const TsdfMap map = twin_map(true);
  const Walk w = walk(test::twin_wing_boxes(true));
  Judged j(map);
  ProofWalk out;
  bool moved = false;
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    std::vector<Pose> others;
    if (i == 0) others.push_back(w.truth[0]);
    // On the scan the track moves, the belief still holds a little of the wing it left.
    if (moved && out.rivals_after_move == 99) others.push_back(half_turn(w.truth[i]));
    const Pose track = moved ? w.truth[i] : half_turn(w.truth[i]);
    const PlaceLedger::Outcome o = j.step(w, i, track, others, track_mapped);
    if (moved && out.rivals_after_move == 99) {
      out.rivals_after_move = o.rivals.size();
      // The image offered again: this scan alone does not favour it by the threshold.
      PlaceLedger::Input again;
      again.track = w.truth[i];
      again.others = {half_turn(w.truth[i])};
      out.rivals_when_offered_again = j.ledger.update(again).rivals.size();
    }
    if (out.proofs > 0) ++out.scans_from_first;
    if (!o.proven) continue;
    if (out.proofs++ == 0) {
      ++out.scans_from_first;
      out.proven_at_x = w.truth[i].translation().x();
      out.share = o.proven->odds_share();
      out.place_error = test::translation_error(o.proven->place, w.truth[i]);
      moved = follows;  // the belief follows the proof from the next scan on
    }
  }
  return out;
}

TEST(PlaceLedger, ProvenBetterOnceTheScansTellThePlacesApart) {
  const ProofWalk p = prove(true, true);
  ASSERT_EQ(p.proofs, 1u);
  EXPECT_GT(p.proven_at_x, 9.7) << "proven before the cabinet came into view";
  EXPECT_GE(p.share, 1.0 / (1.0 + std::exp(-LedgerOptions{}.decide_nats)));
  EXPECT_LT(p.place_error, 0.2);
  EXPECT_EQ(p.rivals_after_move, 0u) << "the wing the track left carries the proof against it";
  EXPECT_EQ(p.rivals_when_offered_again, 0u) << "found again, the left wing stays refuted";
}

// A belief that does not follow the proof is told again on the next scans, while the cabinet's evidence lies within
// the window (the filter judges whether it still needs particles there).
TEST(PlaceLedger, ProvenAgainWhileTheBeliefStays) {
  const ProofWalk p = prove(true, false);
  EXPECT_GT(p.proofs, 1u);
  EXPECT_LT(p.proofs, p.scans_from_first) << "the window moved past the cabinet";
}

TEST(PlaceLedger, NothingProvenWhileTheMapCannotJudgeTheTrack) { EXPECT_EQ(prove(false, true).proofs, 0u); }

// A track carried off the map (a kidnapping): the scans judged it wrong while the map covered them, then it walked into
// unknown space. What was counted stays counted: the rival is proven once the entry spans window_m of travel.
TEST(PlaceLedger, EvidenceGatheredWhileMappedStaysWhenTheTrackLeavesTheMap) {
  const TsdfMap map = twin_map(false);
  const Walk w = walk(test::twin_wing_boxes(false));
  Judged j(map);
  const double against = -2.0 * LedgerOptions{}.decide_nats;
  j.per_scan = &against;
  double walked = 0.0;
  std::size_t first_proof = w.truth.size();
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    if (i > 0) walked += w.motion(i).translation().norm();
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const bool mapped = i < 3;  // 0.6 m of judged travel: less than a proof spans
    const PlaceLedger::Outcome out = j.step(w, i, w.truth[i], others, mapped);
    ASSERT_EQ(out.rivals.size(), 1u) << "scan " << i;
    if (out.proven && first_proof == w.truth.size()) first_proof = i;
    EXPECT_EQ(out.rivals.front().proven, walked >= LedgerOptions{}.window_m) << "scan " << i;
  }
  EXPECT_LT(first_proof, w.truth.size());
}

// Proof needs a view, not a drift: a place favoured by a twentieth of a nat a scan sums past the threshold over a
// long walk, but never within window_m of travel; a nat a scan proves it as soon as the entry spans window_m.
std::size_t first_proof(double evidence_per_scan) {
  const TsdfMap map = twin_map(false);
  const Walk w = walk(test::twin_wing_boxes(false));
  Judged j(map);
  j.per_scan = &evidence_per_scan;
  // The walk there and back again, for a long one.
  std::vector<std::size_t> order;
  for (std::size_t lap = 0; lap < 4; ++lap) {
    for (std::size_t i = 0; i < w.truth.size(); ++i) order.push_back(lap % 2 == 0 ? i : w.truth.size() - 1 - i);
  }
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = order[k];
    j.scan = &w.points[i];
    PlaceLedger::Input in;
    in.motion = k == 0 ? Pose::Identity() : w.truth[order[k - 1]].inverse() * w.truth[i];
    in.track = w.truth[i];
    if (k == 0) in.others.push_back(half_turn(w.truth[i]));
    const PlaceLedger::Outcome out = j.ledger.update(in);
    EXPECT_EQ(out.rivals.size(), 1u) << "scan " << k;
    if (out.proven) return k;
  }
  return order.size();
}

TEST(PlaceLedger, ADriftIsNoProof) {
  const std::size_t scans = 4 * walk(test::twin_wing_boxes(false)).truth.size();
  ASSERT_GT(0.05 * static_cast<double>(scans), 2.0 * LedgerOptions{}.decide_nats) << "the walk is too short";
  EXPECT_EQ(first_proof(-0.05), scans);
  const double window_scans = LedgerOptions{}.window_m / 0.3;
  EXPECT_LE(first_proof(-1.0), static_cast<std::size_t>(std::ceil(window_scans)));
  EXPECT_GE(first_proof(-1.0), static_cast<std::size_t>(std::floor(window_scans))) << "proven before it had standing";
}

// Evidence against one track says nothing against another: when the track moves (a global search's mode gave way to
// another place), a rival's ratio starts over. Against the old track it gathered most of a proof; against the new one
// the scans favour it by a third of a nat each, which never proves it within the window.
TEST(PlaceLedger, EvidenceStartsOverWhenTheTrackMoves) {
  const TsdfMap map = twin_map(false);
  const Walk w = walk(test::twin_wing_boxes(false));
  Judged j(map);
  double per_scan = -1.4;  // for the rival, against whichever track there is
  j.per_scan = &per_scan;
  const Pose elsewhere = pose_from_xyz_rpy(0.0, 1.5, 0.0, 0.0, 0.0, 0.0);  // the other place the track moves to
  for (std::size_t i = 0; i < 12; ++i) {
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const bool moved = i >= 2;
    if (moved) per_scan = -0.3;
    const PlaceLedger::Outcome out = j.step(w, i, moved ? elsewhere * w.truth[i] : w.truth[i], others);
    ASSERT_GE(out.rivals.size(), 1u) << "scan " << i;  // and the place it left
    EXPECT_FALSE(out.proven) << "scan " << i << ": proven by evidence against the track it left";
  }
}

// A place whose points fly out of the map shares no evidence with the track, and so none against it: it must still
// explain the scan to be a rival.
TEST(PlaceLedger, APlaceOffTheMapIsNoRival) {
  const TsdfMap map = twin_map(true);
  const Walk w = walk(test::twin_wing_boxes(true));
  Judged j(map);
  const Pose outside = pose_from_xyz_rpy(-6.0, -6.0, 2.8, 0.0, 0.0, 2.5);
  ASSERT_NEAR(judge(map, w.truth[0], outside, w.points[0]).evidence, 0.0, 1e-9) << "the scene no longer shows it";
  const PlaceLedger::Outcome out = j.step(w, 0, w.truth[0], {outside, half_turn(w.truth[0])});
  ASSERT_EQ(out.rivals.size(), 1u);
  EXPECT_LT(test::translation_error(out.rivals.front().place, half_turn(w.truth[0])), 0.2);
}

// A challenger (the belief moved elsewhere after the first convergence) is held off until the ledger proves it; the
// estimate stays on the track meanwhile. The truth challenges a track on the wrong wing: taken once the cabinet's
// scans prove it over window_m; a challenger the scans refute is refuted, the track kept.
struct Challenge {
  std::size_t held = 0;
  std::optional<std::size_t> taken_at;
  std::optional<std::size_t> refuted_at;
  double taken_x = 0.0;
};

Challenge challenge(bool truth_challenges) {
  const TsdfMap map = twin_map(true);
  const Walk w = walk(test::twin_wing_boxes(true));
  Judged j(map);
  Challenge c;
  bool taken = false;
  for (std::size_t i = 0; i < w.truth.size() && !c.refuted_at; ++i) {
    const Pose truth = w.truth[i];
    const Pose image = half_turn(truth);
    j.scan = &w.points[i];
    PlaceLedger::Input in;
    in.motion = w.motion(i);
    // The track the filter converged on, and the place the belief moved to from scan 2 on.
    in.track = taken ? (truth_challenges ? truth : image) : (truth_challenges ? image : truth);
    if (i >= 2 && !taken) in.challenger = truth_challenges ? truth : image;
    const PlaceLedger::Outcome out = j.ledger.update(in);
    c.held += out.holding ? 1 : 0;
    if (out.challenger_taken && !c.taken_at) {
      c.taken_at = i;
      c.taken_x = truth.translation().x();
      taken = true;
      EXPECT_LT(test::translation_error(out.track, truth), 0.2);
    }
    if (out.challenger_refuted) c.refuted_at = i;
  }
  return c;
}

TEST(PlaceLedger, AChallengerIsHeldOffUntilProven) {
  const Challenge c = challenge(true);
  ASSERT_TRUE(c.taken_at) << "the cabinet proves the truth";
  EXPECT_GT(c.taken_x, 9.7) << "taken before the cabinet came into view";
  EXPECT_GE(c.held, 5u) << "the look-alike wings do not prove the truth before the cabinet";
  EXPECT_FALSE(c.refuted_at);
}

TEST(PlaceLedger, AChallengerTheScansRefuteIsRefuted) {
  const Challenge c = challenge(false);
  EXPECT_FALSE(c.taken_at);
  ASSERT_TRUE(c.refuted_at) << "the cabinet refutes the image";
}

// A track that fails where the map covers its scan (a kidnapping): the challenger is taken after two such updates,
// whatever the travel and the ratio.
TEST(PlaceLedger, ATrackThatFailsOnItsOwnYieldsAtOnce) {
  const TsdfMap map = twin_map(false);
  const Walk w = walk(test::twin_wing_boxes(false));
  Judged j(map);
  const double none = 0.0;
  j.per_scan = &none;
  j.step(w, 0, w.truth[0]);
  const Pose far = half_turn(w.truth[0]);
  std::vector<bool> taken;
  for (std::size_t i = 1; i < 4; ++i) {
    j.scan = &w.points[0];
    PlaceLedger::Input in;
    in.track = w.truth[0];
    in.challenger = far;
    in.track_implausible = i >= 2;
    taken.push_back(j.ledger.update(in).challenger_taken);
  }
  EXPECT_EQ(taken, (std::vector<bool>{false, false, true}));
  EXPECT_LT(test::translation_error(j.ledger.track(), far), 1e-9);
}

TEST(PlaceLedger, OptionsSayWhatIsWrong) {
  const TsdfMap map = twin_map(false);
  LedgerOptions o;
  o.decide_nats = -1.0;
  EXPECT_THROW(Judged(map, o), Error);
  o = LedgerOptions{};
  o.max_rivals = 0;
  EXPECT_THROW(Judged(map, o), Error);
  o = LedgerOptions{};
  o.decide_nats = 0.0;  // off: no rival, a challenger taken at once
  Judged off(map, o);
  EXPECT_FALSE(off.ledger.enabled());
  PlaceLedger::Input in;
  in.others = {pose_from_xyz_rpy(5.0, 0.0, 0.0, 0.0, 0.0, 0.0)};
  in.challenger = pose_from_xyz_rpy(9.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  const PlaceLedger::Outcome out = off.ledger.update(in);
  EXPECT_TRUE(out.rivals.empty());
  EXPECT_TRUE(out.challenger_taken);
}

}  // namespace
}  // namespace tsdf_mcl
