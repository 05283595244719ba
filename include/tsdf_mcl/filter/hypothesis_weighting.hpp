#pragma once
// Evidence between hypotheses, kept apart from the evidence within one.
//
// The joint likelihood of a scan separates a place from its look-alike far too confidently, and noisily: the
// marginal likelihood of a mode is dominated by its best-aligned particles, so of two identical rooms the one
// that happens to hold the luckier particles gains nats by chance every scan, and a random walk of such gains
// decides, within a few hundred scans, a question the data cannot answer. So a hypothesis's share moves by the
// fit of the scan at its mean pose (the mode's own estimate, far steadier than its best particle), counted as a
// scan worth a few independent points; the particles inside it keep their relative weights, which is what
// refines the pose. Equally good places stay equally likely until a view tells them apart; a clearly worse
// place still falls within a scan or two.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tsdf_mcl {

// `prior` and `post`: log weights of n particles before and after one update (any offsets); group[i] in
// [0, evidence.size()) names particle i's hypothesis. Shifts `post` by a constant per group so that every
// group's share becomes prior_share * exp(evidence[g]), renormalized (the shares `post` held are replaced).
// Returns the groups' new shares; groups without particles get 0.
std::vector<double> reweight_groups(const double* prior, double* post, const std::int32_t* group, std::size_t n,
                                    const std::vector<double>& evidence);

// Each place's evidence against the reference place, per point: (reference_total + paired[r]) / points, where
// paired[r] is place r's paired evidence with the reference (scan_fit.hpp: paired_evidence; 0 for the reference
// itself). A place whose pair waits (waits[r]: it lies at the frontier of space the map never observed, so the map
// cannot judge it) gets the best evidence that a judged place earns: it keeps its share against every place,
// where evidence tied with the reference alone would lose it to each look-alike that beats a poor reference.
std::vector<double> place_evidence(double reference_total, const std::vector<double>& paired,
                                   const std::vector<bool>& waits, double points);

// log sum exp of v over each group's particles (groups entries, -inf for an empty group).
std::vector<double> group_log_sums(const double* v, const std::int32_t* group, std::size_t n, std::size_t groups);

}  // namespace tsdf_mcl
