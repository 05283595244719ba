// The evidence between hypotheses: shares set from the prior shares and the per-group evidence, the particles
// inside a group keeping their relative weights.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/hypothesis_weighting.hpp"

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

TEST(HypothesisWeighting, SharesFollowPriorTimesEvidenceAndGroupsKeepTheirInsides) {
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

}  // namespace
}  // namespace tsdf_mcl
