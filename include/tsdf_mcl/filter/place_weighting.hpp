#pragma once
// Evidence between places, kept apart from the evidence within one.
//
// The joint likelihood of a scan separates a place from its look-alike far too confidently, and noisily: the
// marginal likelihood of a mode is dominated by its best-aligned particles, so of two identical rooms the one
// that happens to hold the luckier particles gains nats by chance every scan, and a random walk of such gains
// decides, within a few hundred scans, a question the data cannot answer. So a place's share moves by the
// fit of the scan at its mean pose (the mode's own estimate, far steadier than its best particle), counted as a
// scan worth a few independent points; the particles inside it keep their relative weights, which is what
// refines the pose. Equally good places stay equally likely until a view tells them apart; a clearly worse
// place still falls within a scan or two.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tsdf_mcl {

// `prior` and `post`: log weights of n particles before and after one update (any offsets); group[i] in
// [0, evidence.size()) names particle i's place. Shifts `post` by a constant per group so that every
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

// What one place's fit says about the frontier of space the map never observed (waiting_pairs).
struct FrontierView {
  double coverage = 1.0;          // share of the scan with map evidence (scan_fit.hpp: RayFit::coverage)
  bool fits_as_frontier = false;  // its observed points fit as a frontier's do, or it continues the kept track
  bool near_reference = false;    // within a track's reach of the reference place: a variant of it, not a look-alike
};

// Which places' evidence against the `reference` place waits (place_evidence): where either of the two lies mostly in
// unobserved space (coverage below `most_of_the_scan`) and fits as a frontier does, or where the map covers at least
// `coverage_gap` less of the scan at one of the two and both fit as a frontier does: look-alikes that fit well, not a
// place the scan already refutes, nor variants of one place (near_reference). The second is a door to a room the
// mapping run skipped coming into view: its few observed points, surfaces seen once through that door, fit worse than
// the room's mapped twin long before most of the scan lies in the room. Between variants of one place (a drone's track
// and a sunk copy of it that puts more of the scan on the mapped band) the coverage gap is what the pose changes, and
// the points observed at both judge it. The reference never waits against itself unless it lies mostly in unobserved
// space. No places: none.
std::vector<bool> waiting_pairs(const std::vector<FrontierView>& places, std::size_t reference, double most_of_the_scan,
                                double coverage_gap);

// What a verdict between two places rests on (decisively_beaten): one place's fit at its pose refined onto the map.
struct PlaceJudgement {
  bool compact = false;       // its particles spread within the convergence test's limits
  bool waits = false;         // its evidence waits at the frontier of unmapped space (place_evidence)
  double coverage = 0.0;      // share of the scan with map evidence (scan_fit.hpp: RayFit::coverage)
  double inlier_ratio = 0.0;  // share of those points within the inlier distance of a surface
};

// The places that the best-judged place beats decisively (filter_places.cpp, before the belief first concentrates),
// and in `best` that place (places.size() where none). The best-judged place is the one with the highest `evidence`
// (per point, one per place and then the rest's), if the rest's is no higher; decisive: both compact, neither
// waiting, the map covering at least `min_coverage` of the scan at both, and the best's inlier ratio higher by at
// least `gap`. Two judges agree there, the paired evidence and the raw fit. gap <= 0: none.
std::vector<std::size_t> decisively_beaten(const std::vector<PlaceJudgement>& places,
                                           const std::vector<double>& evidence, double gap, double min_coverage,
                                           std::size_t& best);

// Against each of the `beaten` places, a scan counts as up to `full` points instead of what `nats` holds (each place's
// evidence as reweight_groups takes it, then the rest's; `evidence` the same per point before scaling): as much as
// turns the odds of the `best` place over it (from `prior_log_share`, one per place and then the rest's) to
// `turn_log_odds`, never beyond and never less than `nats` held. The estimate follows (estimate_switch_ratio); only
// the ordinary count concentrates the belief, on which the claim and the look-alike memory's proof wait
// (docs/filter.md, "A decisive view turns the estimate").
void turn_odds(std::size_t best, const std::vector<std::size_t>& beaten, const std::vector<double>& evidence,
               const std::vector<double>& prior_log_share, double full, double turn_log_odds,
               std::vector<double>& nats);

// As a global search first names its places, the places tied with the best fit start equal: shifts `nats` (each
// place's, then the rest's) so that the tied places' shares after the update (from `prior_log_share`, one per place and
// then the rest's) become equal, their sum and every other share kept. Tied: judged as decisively_beaten judges
// (compact, not waiting, the map covering at least `min_coverage` of the scan) and explaining within `gap` as much as
// the best judged place (inlier ratio), so that no view between them is decisive. Between identical places what the
// particles held is how many of the uniform start's guesses landed near each, not evidence; where the places differ in
// what the map never observed it is evidence too (FilterParameters::even_tied_places; docs/filter.md, "A place's last
// pose as a start; tied places started equal"). Returns how many places it evened (0, or 2 and more). gap <= 0: none.
std::size_t even_tied_places(const std::vector<PlaceJudgement>& places, double gap, double min_coverage,
                             const std::vector<double>& prior_log_share, std::vector<double>& nats);

// log sum exp of v over each group's particles (groups entries, -inf for an empty group).
std::vector<double> group_log_sums(const double* v, const std::int32_t* group, std::size_t n, std::size_t groups);

}  // namespace tsdf_mcl
