// LookAlikeMemory (look_alikes.hpp): a place the evidence does not refute is kept, whatever the belief holds there,
// until the scans refute it; a refuted place found again stays refuted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "filter_test_runs.hpp"
#include "filter_test_scene.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/look_alikes.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"

namespace tsdf_mcl {
namespace {

using test::Box;

constexpr float kInlier = 0.2f;

// The twin-wing building's half turn about (12, 4): every view from one wing is the view from the other.
Pose half_turn(const Pose& p) {
  Pose turn = pose_from_xyz_rpy(24.0, 8.0, 0.0, 0.0, 0.0, M_PI);
  return turn * p;
}

struct Walk {
  std::vector<Pose> truth;
  std::vector<std::vector<Eigen::Vector3f>> points;
};

// From room A's middle through its door into the corridor, past the niche whose cabinet tells the wings apart
// (in view from x ~9.7 to 12.5) and on to x 16.5.
Walk walk(const std::vector<Box>& boxes) {
  Walk w;
  w.truth = test::route_through({{3.0, 3.0}, {5.0, 4.0}, {16.5, 4.0}});
  w.points = test::scan_route(boxes, w.truth, 5).points;
  return w;
}

// The filter's judge (ParticleFilter::judge_places): paired evidence on the points both poses observe, clear of the
// frontier, a scan worth 16 points; the share of the scan each pose explains.
LookAlikeMemory::Verdict judge(const TsdfMap& map, const Pose& a, const Pose& b,
                               const std::vector<Eigen::Vector3f>& points) {
  EndpointModel model;
  const double dead_band = 0.5 * kInlier * kInlier / (model.sigma_hit * model.sigma_hit);
  const PointEvidence at_a = point_evidence(map, model, a, points, kInlier, map.truncation());
  const PointEvidence at_b = point_evidence(map, model, b, points, kInlier, map.truncation());
  const PairedEvidence e = paired_evidence(at_a, at_b, dead_band);
  return {16.0 * e.sum / static_cast<double>(points.size()), at_a.fit.absolute_inlier_ratio(),
          at_b.fit.absolute_inlier_ratio()};
}

TsdfMap twin_map(bool with_feature) {
  return test::make_box_map(test::twin_wing_boxes(with_feature), Eigen::Vector3f(-0.2f, -0.2f, -0.2f),
                            Eigen::Vector3f(24.2f, 8.2f, 2.8f));
}

LookAlikeMemory::Judge judge_on(const TsdfMap& map) {
  return [&map](const Pose& a, const Pose& b, const std::vector<Eigen::Vector3f>& points) {
    return judge(map, a, b, points);
  };
}

LookAlikeMemory memory(const TsdfMap& map) {
  return LookAlikeMemory(map, LookAlikeOptions{}, judge_on(map), 0.5, 0.35);
}

// The evidence of a scan for the truth over its image (the cabinet in view: clearly positive).
double told(const TsdfMap& map, const Walk& w, std::size_t i) {
  return judge(map, w.truth[i], half_turn(w.truth[i]), w.points[i]).evidence;
}

TEST(LookAlikes, KeptUntilTheScansRefuteIt) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map = twin_map(true);
  const Walk w = walk(boxes);
  LookAlikeMemory m = memory(map);
  double evidence = 0.0;  // for the truth over the image, scan by scan
  double walked = 0.0;    // m of odometry since the image was found
  bool refuted = false;
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    evidence += told(map, w, i);
    if (i > 0) walked += (w.truth[i - 1].inverse() * w.truth[i]).translation().norm();
    // The belief holds the image only for the first scan: the memory follows it from there on its own.
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const Pose motion = i == 0 ? Pose::Identity() : w.truth[i - 1].inverse() * w.truth[i];
    const std::size_t kept = m.update(w.truth[i], motion, others, w.points[i], true);
    if (evidence < 1.0) {
      ASSERT_EQ(kept, 1u) << "scan " << i << ": the wings look alike so far";
      // Followed where the odometry carries it: the image of the track.
      EXPECT_LT(test::translation_error(m.places().front(), half_turn(w.truth[i])), 0.2) << "scan " << i;
      // Its standing (what the filter restores before the track first converges, once the sum spans proof_window_m):
      // the same place, the travel since it was found, and a sum as even as the scans so far, so about half of the
      // pair's belief.
      const std::vector<LookAlikeMemory::Standing> standing = m.kept();
      ASSERT_EQ(standing.size(), 1u) << "scan " << i;
      EXPECT_LT(test::translation_error(standing.front().place, m.places().front()), 1e-9) << "scan " << i;
      EXPECT_NEAR(standing.front().travelled, walked, 1e-9) << "scan " << i;
      EXPECT_GT(standing.front().odds_share(), 0.2) << "scan " << i << ": evidence " << standing.front().evidence;
    }
    // The memory refines the image on each scan, so its sum differs a little from this one.
    if (evidence > 2.0 * LookAlikeOptions{}.refute_nats) {
      EXPECT_EQ(kept, 0u) << "scan " << i << ": the cabinet was in view";
    }
    refuted = refuted || kept == 0;
  }
  EXPECT_TRUE(refuted) << "the walk never refuted the image (evidence " << evidence << ")";
}

// The image offered again at the end of the walk, where the scan alone does not tell the wings apart (a challenger
// that found it again): refuted at the cabinet, it stays refuted; never judged before, it is kept.
std::size_t offer_again(bool offered_at_start) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map = twin_map(true);
  const Walk w = walk(boxes);
  LookAlikeMemory m = memory(map);
  const std::size_t last = w.truth.size() - 1;
  EXPECT_LT(std::abs(told(map, w, last)), 0.1) << "the last scan alone should not tell the wings apart";
  for (std::size_t i = 0; i < last; ++i) {
    const Pose motion = i == 0 ? Pose::Identity() : w.truth[i - 1].inverse() * w.truth[i];
    std::vector<Pose> others;
    if (i == 0 && offered_at_start) others.push_back(half_turn(w.truth[0]));
    m.update(w.truth[i], motion, others, w.points[i], true);
  }
  EXPECT_TRUE(m.places().empty());
  return m.update(w.truth[last], w.truth[last - 1].inverse() * w.truth[last], {half_turn(w.truth[last])},
                  w.points[last], true);
}

TEST(LookAlikes, RefutedStaysRefutedWhenFoundAgain) { EXPECT_EQ(offer_again(true), 0u); }

TEST(LookAlikes, FoundForTheFirstTimeIsKept) { EXPECT_EQ(offer_again(false), 1u); }

TEST(LookAlikes, FollowsTheTrackWhenItJumps) {
  // The belief's dominant place moves to the image: the look-alikes stay where the odometry carries them, and the
  // old place, as good on every scan, is the look-alike now.
  const std::vector<Box> boxes = test::twin_wing_boxes(false);
  const TsdfMap map = twin_map(false);
  const Walk w = walk(boxes);
  LookAlikeMemory m = memory(map);
  for (std::size_t i = 0; i < 10; ++i) {
    const Pose motion = i == 0 ? Pose::Identity() : w.truth[i - 1].inverse() * w.truth[i];
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const bool jumped = i >= 6;
    const Pose track = jumped ? half_turn(w.truth[i]) : w.truth[i];
    const Pose other = jumped ? w.truth[i] : half_turn(w.truth[i]);
    ASSERT_EQ(m.update(track, motion, others, w.points[i], true), 1u) << "scan " << i;
    EXPECT_LT(test::translation_error(m.places().front(), other), 0.2) << "scan " << i;
  }
}

// The belief on the wrong wing, the truth offered once at the start: when the cabinet comes into view the scans
// prove the truth better, with the share their evidence gives it, on each scan until the track follows; the track
// moving there, the wing it left carries the proof against it and stays refuted. Without the map judging the track's
// scan nothing is proven.
struct ProofWalk {
  std::size_t proofs = 0;            // scans on which the truth was proven better
  std::size_t scans_from_first = 0;  // scans from the first proof on
  double proven_at_x = 0.0;          // m: where the truth was at the first proof
  double share = 0.0;                // its odds share
  double place_error = 1e9;          // m, from the truth
  std::size_t kept_after_move = 99;
  std::size_t kept_when_offered_again = 99;
};

ProofWalk prove(bool track_mapped, bool follows) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map = twin_map(true);
  const Walk w = walk(boxes);
  LookAlikeMemory m = memory(map);
  ProofWalk out;
  bool moved = false;
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    const Pose motion = i == 0 ? Pose::Identity() : w.truth[i - 1].inverse() * w.truth[i];
    std::vector<Pose> others;
    if (i == 0) others.push_back(w.truth[0]);
    // On the scan the track moves, the belief still holds a little of the wing it left.
    if (moved && out.kept_after_move == 99) others.push_back(half_turn(w.truth[i]));
    const Pose track = moved ? w.truth[i] : half_turn(w.truth[i]);
    const std::size_t kept = m.update(track, motion, others, w.points[i], track_mapped);
    if (moved && out.kept_after_move == 99) {
      out.kept_after_move = kept;
      // The image offered again: this scan alone does not favour it by the proof.
      out.kept_when_offered_again = m.update(w.truth[i], Pose::Identity(), {half_turn(w.truth[i])}, w.points[i], true);
    }
    if (out.proofs > 0) ++out.scans_from_first;
    if (!m.proven()) continue;
    if (out.proofs++ == 0) {
      ++out.scans_from_first;
      out.proven_at_x = w.truth[i].translation().x();
      out.share = m.proven()->odds_share();
      out.place_error = test::translation_error(m.proven()->place, w.truth[i]);
      moved = follows;  // the belief follows the proof from the next scan on
    }
  }
  return out;
}

TEST(LookAlikes, ProvenBetterOnceTheScansTellThePlacesApart) {
  const ProofWalk p = prove(true, true);
  ASSERT_EQ(p.proofs, 1u);
  EXPECT_GT(p.proven_at_x, 9.7) << "proven before the cabinet came into view";
  EXPECT_GE(p.share, 1.0 / (1.0 + std::exp(-LookAlikeOptions{}.refute_nats)));
  EXPECT_LT(p.place_error, 0.2);
  EXPECT_EQ(p.kept_after_move, 0u) << "the wing the track left carries the proof against it";
  EXPECT_EQ(p.kept_when_offered_again, 0u) << "found again, the left wing stays refuted";
}

// A belief that does not follow the proof is told again on the next scans, while the cabinet's evidence lies within
// the window (the filter judges whether it still needs particles there).
TEST(LookAlikes, ProvenAgainWhileTheBeliefStays) {
  const ProofWalk p = prove(true, false);
  EXPECT_GT(p.proofs, 1u);
  EXPECT_LT(p.proofs, p.scans_from_first) << "the window moved past the cabinet";
}

TEST(LookAlikes, NothingProvenWhileTheMapCannotJudgeTheTrack) { EXPECT_EQ(prove(false, true).proofs, 0u); }

// Proof needs a view, not a drift: a place favoured by a twentieth of a nat a scan sums past the bound over a long
// walk, but never within proof_window_m of travel; a nat a scan proves it within the window.
std::size_t first_proof(double evidence_per_scan) {
  const std::vector<Box> boxes = test::twin_wing_boxes(false);
  const TsdfMap map = twin_map(false);
  const Walk w = walk(boxes);
  const LookAlikeMemory::Judge fixed = [&map, evidence_per_scan](const Pose& a, const Pose& b,
                                                                 const std::vector<Eigen::Vector3f>& points) {
    LookAlikeMemory::Verdict v = judge(map, a, b, points);
    v.evidence = evidence_per_scan;
    return v;
  };
  LookAlikeMemory m(map, LookAlikeOptions{}, fixed, 0.5, 0.35);
  // The walk there and back again, for a long one (0.3 m a scan).
  std::vector<std::size_t> order;
  for (std::size_t lap = 0; lap < 4; ++lap) {
    for (std::size_t i = 0; i < w.truth.size(); ++i) order.push_back(lap % 2 == 0 ? i : w.truth.size() - 1 - i);
  }
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = order[k];
    const Pose motion = k == 0 ? Pose::Identity() : w.truth[order[k - 1]].inverse() * w.truth[i];
    std::vector<Pose> others;
    if (k == 0) others.push_back(half_turn(w.truth[i]));
    EXPECT_EQ(m.update(w.truth[i], motion, others, w.points[i], true), 1u) << "scan " << k;
    if (m.proven()) return k;
  }
  return order.size();
}

TEST(LookAlikes, ADriftIsNoProof) {
  const std::size_t scans = 4 * walk(test::twin_wing_boxes(false)).truth.size();
  ASSERT_GT(0.05 * static_cast<double>(scans), 2.0 * LookAlikeOptions{}.refute_nats) << "the walk is too short";
  EXPECT_EQ(first_proof(-0.05), scans);
  const double window_scans = LookAlikeOptions{}.proof_window_m / 0.3;
  EXPECT_LE(first_proof(-1.0), static_cast<std::size_t>(window_scans));
}

// Evidence against one track says nothing against another: when the track jumps (a global search's mode gave way
// to another place), a kept look-alike's sums start over. Against the old track it gathered most of a proof; against
// the new one the scans favour it by a third of a nat each, which never proves it within the window.
TEST(LookAlikes, EvidenceStartsOverWhenTheTrackJumps) {
  const std::vector<Box> boxes = test::twin_wing_boxes(false);
  const TsdfMap map = twin_map(false);
  const Walk w = walk(boxes);
  double per_scan = -1.4;  // for the look-alike, against whichever track there is
  const LookAlikeMemory::Judge fixed = [&](const Pose& a, const Pose& b, const std::vector<Eigen::Vector3f>& points) {
    LookAlikeMemory::Verdict v = judge(map, a, b, points);
    v.evidence = per_scan;
    return v;
  };
  LookAlikeMemory m(map, LookAlikeOptions{}, fixed, 0.5, 0.35);
  const Pose elsewhere = pose_from_xyz_rpy(0.0, 1.5, 0.0, 0.0, 0.0, 0.0);  // the other place the track jumps to
  for (std::size_t i = 0; i < 12; ++i) {
    const Pose motion = i == 0 ? Pose::Identity() : w.truth[i - 1].inverse() * w.truth[i];
    std::vector<Pose> others;
    if (i == 0) others.push_back(half_turn(w.truth[0]));
    const bool jumped = i >= 2;
    if (jumped) per_scan = -0.3;
    const Pose track = jumped ? elsewhere * w.truth[i] : w.truth[i];
    ASSERT_GE(m.update(track, motion, others, w.points[i], true), 1u) << "scan " << i;  // and the place it left
    EXPECT_FALSE(m.proven()) << "scan " << i << ": proven by evidence against the track it left";
  }
}

// A place whose points fly out of the map shares no evidence with the track, and so none against it: it must still
// explain the scan to be a look-alike.
TEST(LookAlikes, APlaceOffTheMapIsNone) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map = twin_map(true);
  const Walk w = walk(boxes);
  LookAlikeMemory m = memory(map);
  const Pose outside = pose_from_xyz_rpy(-6.0, -6.0, 2.8, 0.0, 0.0, 2.5);
  ASSERT_NEAR(judge(map, w.truth[0], outside, w.points[0]).evidence, 0.0, 1e-9) << "the scene no longer shows it";
  EXPECT_EQ(m.update(w.truth[0], Pose::Identity(), {outside, half_turn(w.truth[0])}, w.points[0], true), 1u);
  EXPECT_LT(test::translation_error(m.places().front(), half_turn(w.truth[0])), 0.2);
}

TEST(LookAlikes, OptionsSayWhatIsWrong) {
  const TsdfMap map = twin_map(false);
  const auto make = [&](const LookAlikeOptions& o) { return LookAlikeMemory(map, o, judge_on(map), 0.5, 0.35); };
  LookAlikeOptions o;
  o.refute_nats = -1.0;
  EXPECT_THROW(make(o), Error);
  o = LookAlikeOptions{};
  o.max_places = 0;
  EXPECT_THROW(make(o), Error);
  o = LookAlikeOptions{};
  o.refute_nats = 0.0;  // off
  LookAlikeMemory off = make(o);
  EXPECT_FALSE(off.enabled());
  EXPECT_EQ(off.update(Pose::Identity(), Pose::Identity(), {pose_from_xyz_rpy(5.0, 0.0, 0.0, 0.0, 0.0, 0.0)}, {}, true),
            0u);
}

}  // namespace
}  // namespace tsdf_mcl
