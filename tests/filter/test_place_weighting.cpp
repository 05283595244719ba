// The evidence between hypotheses: shares set from the prior shares and the per-group evidence, the particles
// inside a group keeping their relative weights.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/place_weighting.hpp"

namespace tsdf_mcl {
namespace {

double share_of(const std::vector<double>& post, const std::vector<std::int32_t>& group, std::int32_t g) {
  double in = 0.0, all = 0.0;
  for (std::size_t i = 0; i < post.size(); ++i) {
    all += std::exp(post[i]);
    if (group[i] == g) in += std::exp(post[i]);
  }
  return in / all;
}

TEST(PlaceWeighting, SharesFollowPriorTimesEvidenceAndGroupsKeepTheirInsides) {
  // Group 0 holds 3/4 of the prior, group 1 1/4; the update made group 1's particles far likelier (the post
  // shares would be 0.01 / 0.99), but the evidence says e^1 in favour of group 1.
  const std::vector<std::int32_t> group = {0, 0, 0, 1, 1};
  const std::vector<double> prior = {std::log(0.25), std::log(0.25), std::log(0.25), std::log(0.125), std::log(0.125)};
  std::vector<double> post = {prior[0] - 5.0, prior[1] - 5.5, prior[2] - 4.0, prior[3], prior[4] + 0.3};
  const std::vector<double> before = post;
  const std::vector<double> share = reweight_groups(prior.data(), post.data(), group.data(), 5, {0.0, 1.0});
  const double expected1 = 0.25 * std::exp(1.0) / (0.75 + 0.25 * std::exp(1.0));
  EXPECT_NEAR(share[1], expected1, 1e-12);
  EXPECT_NEAR(share[0], 1.0 - expected1, 1e-12);
  EXPECT_NEAR(share_of(post, group, 1), expected1, 1e-12);
  // Inside a group the relative weights are those of the update.
  EXPECT_NEAR(post[1] - post[0], before[1] - before[0], 1e-12);
  EXPECT_NEAR(post[4] - post[3], before[4] - before[3], 1e-12);
  // Equal evidence keeps the prior shares, whatever the update did to the particles.
  std::vector<double> again = before;
  const std::vector<double> equal = reweight_groups(prior.data(), again.data(), group.data(), 5, {2.0, 2.0});
  EXPECT_NEAR(equal[0], 0.75, 1e-12);
  // An empty group gets nothing; bad groups and evidence are errors.
  std::vector<double> third = before;
  EXPECT_EQ(reweight_groups(prior.data(), third.data(), group.data(), 5, {0.0, 0.0, 5.0})[2], 0.0);
  const std::vector<std::int32_t> bad = {0, 0, 0, 1, 2};
  EXPECT_THROW(reweight_groups(prior.data(), third.data(), bad.data(), 5, {0.0, 0.0}), Error);
  EXPECT_THROW(reweight_groups(prior.data(), third.data(), group.data(), 5, {0.0, std::nan("")}), Error);
}

TEST(PlaceWeighting, APlaceThatWaitsKeepsItsShareAgainstEveryPlace) {
  // The symmetric building's drone (measured): the right track (place 1, 0.96 of the belief) at the frontier of the
  // map's band, its mirror (place 0) beating the best-total third place (2, the reference) by 54 nats on 512 points.
  const double points = 512.0;
  const std::vector<double> paired = {54.0, 0.0, 0.0};
  const std::vector<bool> waits = {false, true, false};
  const std::vector<double> e = place_evidence(100.0, paired, waits, points);
  EXPECT_DOUBLE_EQ(e[0], 154.0 / points);
  EXPECT_DOUBLE_EQ(e[1], e[0]);  // tied with the best judged place, not with the reference
  EXPECT_DOUBLE_EQ(e[2], 100.0 / points);
  // Over the update the track keeps its share against the mirror; the third place loses to both.
  const std::vector<std::int32_t> group = {0, 1, 2};
  const std::vector<double> prior = {std::log(0.04), std::log(0.96), std::log(1e-3)};
  std::vector<double> post = prior;
  std::vector<double> scaled;
  for (double v : e) scaled.push_back(16.0 * (v - e[0]));  // hypothesis_evidence_points per point, best at 0
  const std::vector<double> share = reweight_groups(prior.data(), post.data(), group.data(), 3, scaled);
  EXPECT_NEAR(share[1] / share[0], 0.96 / 0.04, 1e-9);
  EXPECT_LT(share[2], 1e-3 * std::exp(-1.0));
  // Judged places keep their paired evidence; where every pair waits, all tie with the reference.
  const std::vector<double> none = place_evidence(100.0, paired, {true, true, true}, points);
  for (double v : none) EXPECT_DOUBLE_EQ(v, 100.0 / points);
  // Where the reference is the best judged place, a waiting place ties with it (as a pair of places did before).
  const std::vector<double> best_ref = place_evidence(100.0, {-30.0, 0.0, 0.0}, {false, false, true}, points);
  EXPECT_DOUBLE_EQ(best_ref[2], 100.0 / points);
  EXPECT_DOUBLE_EQ(best_ref[0], 70.0 / points);
  EXPECT_THROW(place_evidence(100.0, paired, {true}, points), Error);
  EXPECT_THROW(place_evidence(100.0, paired, waits, 0.0), Error);
}

TEST(PlaceWeighting, ADecisiveViewNeedsTwoJudgesAFullMapAndCompactPlaces) {
  // The two storeys of the two-storey VLP-16 handheld run at the staircase (measured): the true storey (place 0, the
  // best judged) explains 0.98 of its observed points, the other 0.94; a third, spread place; the rest.
  const PlaceJudgement storey{true, false, 0.97, 0.98};
  const PlaceJudgement twin{true, false, 0.96, 0.94};
  const PlaceJudgement spread{false, false, 0.97, 0.70};
  const std::vector<double> evidence = {-0.80, -0.82, -1.50, -1.20};
  const double gap = 0.03, covered = 0.9;
  std::size_t best = 99;
  EXPECT_EQ(decisively_beaten({storey, twin, spread}, evidence, gap, covered, best), std::vector<std::size_t>{1});
  EXPECT_EQ(best, 0u);
  // Each condition alone leaves no verdict: a gap under 0.03, a map that covers less of the scan at either place (a
  // room the mapping run skipped), a place waiting at the frontier or spread, the raw fit disagreeing with the
  // paired evidence (the place it favours is not the best judged).
  const PlaceJudgement close{true, false, 0.96, 0.955};
  PlaceJudgement skipped = storey;
  skipped.coverage = 0.6;
  PlaceJudgement waiting = twin;
  waiting.waits = true;
  PlaceJudgement wide = twin;
  wide.compact = false;
  for (const std::vector<PlaceJudgement>& places :
       {std::vector<PlaceJudgement>{storey, close, spread}, std::vector<PlaceJudgement>{skipped, twin, spread},
        std::vector<PlaceJudgement>{storey, waiting, spread}, std::vector<PlaceJudgement>{storey, wide, spread},
        std::vector<PlaceJudgement>{twin, storey, spread}}) {
    EXPECT_TRUE(decisively_beaten(places, evidence, gap, covered, best).empty());
  }
  // Nor where the rest is judged best (it has no pose to judge a fit at), or the rule is off.
  EXPECT_TRUE(decisively_beaten({storey, twin, spread}, {-0.8, -0.82, -1.5, -0.5}, gap, covered, best).empty());
  EXPECT_EQ(best, 3u);
  EXPECT_TRUE(decisively_beaten({storey, twin, spread}, evidence, 0.0, covered, best).empty());
  EXPECT_THROW(decisively_beaten({storey, twin}, evidence, gap, covered, best), Error);
}

TEST(PlaceWeighting, ADecisiveViewTurnsTheOddsAndNoFurther) {
  // The storeys above: the true one (0) holds 0.3 of the belief against 0.7 and beats the other decisively.
  const std::vector<double> evidence = {-0.80, -0.82, -1.50, -1.20};
  const std::vector<double> prior = {std::log(0.3), std::log(0.7), std::log(1e-3), std::log(1e-3)};
  const double tempered = 4.0, full = 64.0;
  const double turn = 2.0 * std::log(1.2);  // the estimate's switch ratio, squared
  const auto ordinary = [&](const std::vector<double>& e) {
    std::vector<double> nats;
    for (double v : e) nats.push_back(tempered * (v - e[0]));
    return nats;
  };
  std::vector<double> nats = ordinary(evidence);
  turn_odds(0, {1}, evidence, prior, full, turn, nats);
  // In full the twin would lose 1.28 nats; 1.21 turn the odds to 1.44 : 1, and no more is taken.
  EXPECT_NEAR(nats[1], std::log(0.3) - std::log(0.7) - turn, 1e-12);
  const std::vector<double> untouched = ordinary(evidence);
  EXPECT_EQ(nats[0], untouched[0]);
  EXPECT_EQ(nats[2], untouched[2]);
  EXPECT_EQ(nats[3], untouched[3]);
  const std::vector<std::int32_t> group = {0, 1, 2, 3};
  std::vector<double> post = prior;
  const std::vector<double> share = reweight_groups(prior.data(), post.data(), group.data(), 4, nats);
  EXPECT_NEAR(share[0] / share[1], 1.44, 1e-9);
  // Where the count in full turns less, it is all taken.
  std::vector<double> small = evidence;
  small[1] = -0.81;
  nats = ordinary(small);
  turn_odds(0, {1}, small, prior, full, turn, nats);
  EXPECT_NEAR(nats[1], full * -0.01, 1e-12);
  // A place already turned past the odds keeps the ordinary count: the view does not concentrate the belief.
  const std::vector<double> leading = {std::log(0.8), std::log(0.2), std::log(1e-3), std::log(1e-3)};
  nats = ordinary(evidence);
  turn_odds(0, {1}, evidence, leading, full, turn, nats);
  EXPECT_EQ(nats, ordinary(evidence));
  EXPECT_THROW(turn_odds(0, {0}, evidence, prior, full, turn, nats), Error);
  EXPECT_THROW(turn_odds(3, {1}, evidence, prior, full, turn, nats), Error);
}

TEST(PlaceWeighting, TiedPlacesStartEqualWhateverTheParticlesHeld) {
  // Two identical wings (0, 1) that a uniform start's guesses found 2 : 1, a look-alike 0.05 worse (2), one the map
  // hardly covers (3), a spread mode (4), then the rest.
  const std::vector<PlaceJudgement> places = {{true, false, 0.98, 1.00},
                                              {true, false, 0.97, 0.99},
                                              {true, false, 0.96, 0.95},
                                              {true, false, 0.60, 1.00},
                                              {false, false, 0.99, 1.00}};
  const std::vector<double> prior = {std::log(0.4), std::log(0.2), std::log(0.1),
                                     std::log(0.1), std::log(0.1), std::log(0.1)};
  const std::vector<double> ordinary = {0.0, -0.01, -0.3, 0.0, -0.02, -0.1};
  std::vector<double> nats = ordinary;
  EXPECT_EQ(even_tied_places(places, 0.03, 0.9, prior, nats), 2u);
  const std::vector<std::int32_t> group = {0, 1, 2, 3, 4, 5};
  std::vector<double> post = prior;
  const std::vector<double> share = reweight_groups(prior.data(), post.data(), group.data(), 6, nats);
  std::vector<double> post_ordinary = prior;
  const std::vector<double> before = reweight_groups(prior.data(), post_ordinary.data(), group.data(), 6, ordinary);
  EXPECT_NEAR(share[0], share[1], 1e-12);
  EXPECT_NEAR(share[0] + share[1], before[0] + before[1], 1e-12);  // their sum kept, and every other share
  for (std::size_t g = 2; g < 6; ++g) EXPECT_NEAR(share[g], before[g], 1e-12) << g;
  // A third place within the gap joins them; a place the best beats decisively keeps its share.
  std::vector<PlaceJudgement> three = places;
  three[2].inlier_ratio = 0.975;
  nats = ordinary;
  EXPECT_EQ(even_tied_places(three, 0.03, 0.9, prior, nats), 3u);
  EXPECT_NEAR(prior[1] + nats[1], prior[2] + nats[2], 1e-12);
  // A waiting place is not judged; alone with its twin the best has no tie; gap 0 evens nothing.
  std::vector<PlaceJudgement> waiting = places;
  waiting[1].waits = true;
  nats = ordinary;
  EXPECT_EQ(even_tied_places(waiting, 0.03, 0.9, prior, nats), 0u);
  EXPECT_EQ(nats, ordinary);
  EXPECT_EQ(even_tied_places(places, 0.0, 0.9, prior, nats), 0u);
  EXPECT_EQ(nats, ordinary);
  // An empty group is no place to even.
  std::vector<double> empty = prior;
  empty[1] = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(even_tied_places(places, 0.03, 0.9, empty, nats), 0u);
  EXPECT_THROW(even_tied_places(places, 0.03, 0.9, {0.0}, nats), Error);
}

// The pairs whose evidence waits: a place mostly off the observed map (either side of the pair), and a pair where the
// map covers clearly less of the scan at one place, as a skipped room's door comes into view. Only where both fit as a
// frontier does: a place that fits its observed points badly is judged as before.
TEST(PlaceWeighting, APairWaitsWhereADoorToUnobservedSpaceComesIntoView) {
  const double most = 0.75, gap = 0.05;
  // 0: the reference, covered; 1: its twin, covered; 2: a door in view; 3: the same gap, fitting badly;
  // 4: mostly unobserved; 5: covered, fitting badly (refuted).
  const std::vector<FrontierView> places = {{0.99, true},  {0.98, true}, {0.90, true},
                                            {0.90, false}, {0.60, true}, {0.99, false}};
  EXPECT_EQ(waiting_pairs(places, 0, most, gap), (std::vector<bool>{false, false, true, false, true, false}));
  // Gap 0 keeps only the rule of the mostly unobserved place.
  EXPECT_EQ(waiting_pairs(places, 0, most, 0.0), (std::vector<bool>{false, false, false, false, true, false}));
  // With the door in view at the reference, every place that fits well and is covered clearly more waits against it;
  // the one covered as little and the refuted one do not.
  EXPECT_EQ(waiting_pairs(places, 2, most, gap), (std::vector<bool>{true, true, false, false, true, false}));
  // A reference mostly off the observed map makes every pair wait; one that fits badly there does not.
  EXPECT_EQ(waiting_pairs(places, 4, most, gap), (std::vector<bool>{true, true, true, true, true, true}));
  std::vector<FrontierView> bad = places;
  bad[4].fits_as_frontier = false;
  EXPECT_EQ(waiting_pairs(bad, 0, most, gap), (std::vector<bool>{false, false, true, false, false, false}));
  // A variant of the reference (a sunk copy of a drone's track) is judged on the points observed at both.
  std::vector<FrontierView> variant = places;
  variant[2].near_reference = true;
  EXPECT_EQ(waiting_pairs(variant, 0, most, gap), (std::vector<bool>{false, false, false, false, true, false}));
  EXPECT_THROW(waiting_pairs(places, 6, most, gap), Error);
  EXPECT_TRUE(waiting_pairs({}, 0, most, gap).empty());
}

}  // namespace
}  // namespace tsdf_mcl
