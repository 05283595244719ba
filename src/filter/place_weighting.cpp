#include "tsdf_mcl/filter/place_weighting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {
constexpr double kMinusInf = -std::numeric_limits<double>::infinity();

// Whether the map can judge a place's fit: compact, not waiting at the frontier, the scan covered enough.
bool judged(const PlaceJudgement& p, double min_coverage) {
  return p.compact && !p.waits && p.coverage >= min_coverage;
}
}  // namespace

std::vector<double> group_log_sums(const double* v, const std::int32_t* group, std::size_t n, std::size_t groups) {
  double max = kMinusInf;
  for (std::size_t i = 0; i < n; ++i) {
    if (group[i] < 0 || static_cast<std::size_t>(group[i]) >= groups) throw Error("place weighting: bad group");
    max = std::max(max, v[i]);
  }
  std::vector<double> sum(groups, 0.0);
  for (std::size_t i = 0; i < n; ++i) sum[static_cast<std::size_t>(group[i])] += std::exp(v[i] - max);
  for (double& s : sum) s = s > 0.0 ? std::log(s) + max : kMinusInf;
  return sum;
}

std::vector<double> place_evidence(double reference_total, const std::vector<double>& paired,
                                   const std::vector<bool>& waits, double points) {
  if (paired.size() != waits.size()) throw Error("place weighting: one wait flag per place");
  if (!(points > 0.0)) throw Error("place weighting: the evidence needs points");
  std::vector<double> evidence(paired.size());
  double best_judged = reference_total / points;  // the reference's own, also where every pair waits
  for (std::size_t r = 0; r < paired.size(); ++r) {
    evidence[r] = (reference_total + (waits[r] ? 0.0 : paired[r])) / points;
    if (!waits[r]) best_judged = std::max(best_judged, evidence[r]);
  }
  for (std::size_t r = 0; r < paired.size(); ++r) {
    if (waits[r]) evidence[r] = best_judged;
  }
  return evidence;
}

std::vector<bool> waiting_pairs(const std::vector<FrontierView>& places, std::size_t reference, double most_of_the_scan,
                                double coverage_gap) {
  if (places.empty()) return {};  // no places: nothing to pair
  if (reference >= places.size()) throw Error("place weighting: the reference must be a place");
  const auto mostly_unobserved = [&](const FrontierView& p) {
    return p.coverage < most_of_the_scan && p.fits_as_frontier;
  };
  const FrontierView& ref = places[reference];
  std::vector<bool> waits(places.size(), false);
  for (std::size_t r = 0; r < places.size(); ++r) {
    // Both fit their observed points well: look-alikes, not a place the scan already refutes.
    const bool door_in_view = !places[r].near_reference && places[r].fits_as_frontier && ref.fits_as_frontier &&
                              std::abs(places[r].coverage - ref.coverage) >= coverage_gap;
    waits[r] = mostly_unobserved(places[r]) || mostly_unobserved(ref) || (coverage_gap > 0.0 && door_in_view);
  }
  return waits;
}

std::vector<std::size_t> decisively_beaten(const std::vector<PlaceJudgement>& places,
                                           const std::vector<double>& evidence, double gap, double min_coverage,
                                           std::size_t& best) {
  if (evidence.size() != places.size() + 1) throw Error("place weighting: one evidence per place and the rest");
  best = places.size();
  std::vector<std::size_t> beaten;
  if (!(gap > 0.0) || places.empty()) return beaten;
  const auto b = static_cast<std::size_t>(
      std::max_element(evidence.begin(), evidence.begin() + static_cast<std::ptrdiff_t>(places.size())) -
      evidence.begin());
  if (evidence[b] < evidence.back()) return beaten;  // the rest has no pose to judge a fit at
  if (!judged(places[b], min_coverage)) return beaten;
  best = b;
  for (std::size_t r = 0; r < places.size(); ++r) {
    if (r != b && judged(places[r], min_coverage) && places[b].inlier_ratio - places[r].inlier_ratio >= gap)
      beaten.push_back(r);
  }
  return beaten;
}

void turn_odds(std::size_t best, const std::vector<std::size_t>& beaten, const std::vector<double>& evidence,
               const std::vector<double>& prior_log_share, double full, double turn_log_odds,
               std::vector<double>& nats) {
  if (evidence.size() != nats.size() || prior_log_share.size() != nats.size())
    throw Error("place weighting: one evidence, share and count per place and the rest");
  if (beaten.empty()) return;
  if (best + 1 >= nats.size()) throw Error("place weighting: the best place must be a place");
  const std::size_t b = best;
  if (!std::isfinite(prior_log_share[b])) return;
  for (const std::size_t r : beaten) {
    if (r + 1 >= nats.size() || r == b) throw Error("place weighting: a beaten place must be another place");
    if (!std::isfinite(prior_log_share[r])) continue;
    // r's nats that leave b's odds over r at turn_log_odds; the count in full; what the ordinary count gave.
    const double turned = (prior_log_share[b] + nats[b]) - prior_log_share[r] - turn_log_odds;
    const double counted = nats[b] + full * (evidence[r] - evidence[b]);
    nats[r] = std::min(nats[r], std::max(counted, turned));
  }
}

std::size_t even_tied_places(const std::vector<PlaceJudgement>& places, double gap, double min_coverage,
                             const std::vector<double>& prior_log_share, std::vector<double>& nats) {
  if (prior_log_share.size() != places.size() + 1 || nats.size() != places.size() + 1)
    throw Error("place weighting: one share and count per place and the rest");
  if (!(gap > 0.0)) return 0;
  const auto even = [&](std::size_t r) { return judged(places[r], min_coverage) && std::isfinite(prior_log_share[r]); };
  double best = -1.0;
  for (std::size_t r = 0; r < places.size(); ++r) {
    if (even(r)) best = std::max(best, places[r].inlier_ratio);
  }
  std::vector<std::size_t> tied;
  double max = kMinusInf;
  for (std::size_t r = 0; r < places.size(); ++r) {
    if (!even(r) || best - places[r].inlier_ratio >= gap) continue;
    tied.push_back(r);
    max = std::max(max, prior_log_share[r] + nats[r]);
  }
  if (tied.size() < 2) return 0;
  double sum = 0.0;
  for (const std::size_t r : tied) sum += std::exp(prior_log_share[r] + nats[r] - max);
  const double each = max + std::log(sum / static_cast<double>(tied.size()));
  for (const std::size_t r : tied) nats[r] = each - prior_log_share[r];
  return tied.size();
}

std::vector<double> reweight_groups(const double* prior, double* post, const std::int32_t* group, std::size_t n,
                                    const std::vector<double>& evidence) {
  const std::size_t groups = evidence.size();
  for (double e : evidence) {
    if (!std::isfinite(e)) throw Error("place weighting: evidence must be finite");
  }
  const std::vector<double> before = group_log_sums(prior, group, n, groups);
  const std::vector<double> after = group_log_sums(post, group, n, groups);
  std::vector<double> log_share(groups, kMinusInf);
  double max = kMinusInf;
  for (std::size_t g = 0; g < groups; ++g) {
    if (before[g] == kMinusInf || after[g] == kMinusInf) continue;
    log_share[g] = before[g] + evidence[g];  // prior share (unnormalized) times the evidence
    max = std::max(max, log_share[g]);
  }
  double total = 0.0;
  for (double l : log_share) total += l == kMinusInf ? 0.0 : std::exp(l - max);
  std::vector<double> share(groups, 0.0);
  std::vector<double> shift(groups, 0.0);
  for (std::size_t g = 0; g < groups; ++g) {
    if (log_share[g] == kMinusInf) continue;
    const double normalized = log_share[g] - max - std::log(total);
    share[g] = std::exp(normalized);
    // Relative shifts are all that matter (weights are normalized later): the group's post weights, summing to
    // exp(after[g]), must sum to exp(normalized) times a common constant.
    shift[g] = normalized - after[g];
  }
  for (std::size_t i = 0; i < n; ++i) post[i] += shift[static_cast<std::size_t>(group[i])];
  return share;
}

}  // namespace tsdf_mcl
