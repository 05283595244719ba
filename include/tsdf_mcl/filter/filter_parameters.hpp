#pragma once
// Everything that tunes the particle filter, in one struct of option structs, each named after the stage it tunes
// (docs/filter.md has the stages; docs/parameters.md lists the ones localize exposes, generated from its table).
// Defaults need no priors: a global search from the first scan, nav2 AMCL's meaning where a name carries over.
#include <cstddef>
#include <cstdint>

#include "tsdf_mcl/filter/global_proposal.hpp"
#include "tsdf_mcl/filter/kld_sampling.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/particle_init.hpp"
#include "tsdf_mcl/filter/place_ledger.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/filter/resampling.hpp"
#include "tsdf_mcl/filter/same_place.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"
#include "tsdf_mcl/filter/track_state_machine.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"

namespace tsdf_mcl {

// The endpoint model with the filter's tempering, weight_exponent 0.2. Neighbouring beams and successive scans see the
// same surfaces with the same map errors, so the untempered product of 500 points per scan, one scan per 0.1 m,
// collapses a global belief within a metre of travel onto whichever of two look-alike rooms a particle happened to fit
// best (docs/filter.md).
inline EndpointModel filter_sensor_model() {
  EndpointModel m;
  m.weight_exponent = 0.2f;
  return m;
}

// Global localization from a scan: a large set of hypotheses from the proposal (global_proposal.hpp), each scored on a
// few points of the scan with a wide likelihood (about the map's truncation, so that one a few decimetres or degrees
// off still scores), the best kept as the initial particles, then each climbing on its own: per round three jittered
// copies (0.1 m / 1.7° in the first round, half that in the second) scored on twice the points.
struct GlobalSearchOptions {
  std::size_t candidates = 1000000;  // init_candidates (fewer than the initial particles: no screening)
  std::size_t screen_points = 64;
  float screen_sigma = 0.3f;  // m
  std::size_t climb_rounds = 2;
  ProposalOptions proposal;

  void validate() const;  // throws Error naming the parameter
};

// Until the filter first converges, every update adds a random walk of these standard deviations per axis to the
// motion noise (not while the dominant place holds the belief, concentrated), and a scan the motion gate would hold is
// still an update once `interval` has passed. A global belief is sparse: its particles nearest the true pose are
// decimetres and degrees off; the walk lets them climb the likelihood before selection judges them.
struct RougheningOptions {
  double xyz = 0.1;       // m
  double angle = 0.04;    // rad
  double interval = 1.0;  // s
};

// Recovery from a lost track (recovery.hpp) and from a wrong lock.
struct RecoveryOptions {
  // Augmented MCL on the track's inlier ratio: share = 1 - w_fast / (w_slow (1 - margin)). Both alphas 0 = off.
  double alpha_slow = 0.02;  // recovery_alpha_slow
  double alpha_fast = 0.1;   // recovery_alpha_fast
  double margin = 0.3;
  // Once the belief has concentrated, a dominant place whose inlier ratio stays below this for two updates is a wrong
  // lock however steady its fit: a share 1 - ratio / this of the next generation comes from the proposal, screened on
  // the scan, and the filter searches again. 0 = off.
  double min_inliers = 0.3;  // recovery_min_inliers
  // Challengers, a background search once the belief has concentrated (after a local start, also once the updates a
  // claim takes have passed without):
  // every challenger_interval seconds this many hypotheses from the proposal are screened on the scan and the best
  // 1/200 join the belief with a tenth of PlaceOptions::credible_weight together (one scan a challenger explains
  // clearly better makes it credible); the particles outside the heaviest places keep that many through
  // resampling. 0 candidates = off.
  std::size_t challenger_candidates = 20000;
  double challenger_interval = 0.5;  // s

  void validate() const;
};

// The places of the belief: how the evidence between them moves their shares (place_weighting.hpp), which points are
// evidence at a place (observation_mask.hpp), and how a place is weighed on its own points.
struct PlaceOptions {
  // Between places a scan is worth this many independent points (fewer while the tempering counts it as fewer).
  double evidence_points = 64.0;
  std::size_t min_particles = 200;  // a place holding min_weight keeps at least this many particles
  double min_weight = 1e-5;
  // A place holding this share is credible: every credible place keeps as many particles as the largest (with fewer,
  // its mean sits a little off, and the evidence drifts towards whichever look-alike held more particles).
  double credible_weight = 1e-3;
  float inlier_distance = 0.2f;  // m: a point within this of a surface explains it
  // The estimate stays on the place it reported until another holds this many times that place's share.
  double switch_ratio = 1.2;
  // Before the first concentration a view where the best-judged place explains this much more of its observed points
  // (inlier ratio), on two updates in a row, turns the odds to switch_ratio squared. 0 = off.
  double decisive_inlier_gap = 0.03;
  bool even_tied = true;               // places tied with the best fit start equal as a global search names them
  bool frontier_evidence = false;      // points at the frontier of observed space count as evidence
  double see_through_weight = 1.0;     // a place's height weighed on the scan's rays (0 = off)
  double wall_tilt_information = 3.0;  // the scan's walls hold the refined tilt (per wall, against 512 points)
  // The observation mask's shares of the scan (docs/filter.md, "Which points are evidence").
  double most_of_the_scan = 0.75;       // coverage at which the fit judges a place
  double nearly_all_of_the_scan = 0.9;  // coverage at both places for a decisive view
  double frontier_min_inliers = 0.8;    // a place at the frontier fits its observed points at least this well
  double frontier_coverage_gap = 0.05;  // a door into unobserved space: this much less coverage at one place
  double refine_again_gap = 0.01;       // a compact place fitting this much worse is refined again ...
  std::size_t refine_starts = 8;        // ... from this many of its heaviest particles
  // A place is weighed on its own points (within track_radius of its predicted pose, at most max_own_places places)
  // where at least min_own_points of them are left.
  std::size_t min_own_points = 32;
  double track_radius = 2.0;  // m
  std::size_t max_own_places = 4;
  std::size_t fittest_places = 4;         // places outside the belief's that the ledger weighs each update
  std::size_t mapped_track_updates = 10;  // updates at a covered place before the frontier rules apply

  void validate() const;
};

struct FilterParameters {
  std::size_t initial_particles = 100000;  // particles of a global or local initialization
  KldParameters kld;                       // min_particles, max_particles, pf_err, pf_z, bins
  ResamplingMethod resample_method = ResamplingMethod::kSystematic;
  // Resampling is considered every resample_interval-th update, and done when the effective sample size is below
  // resample_ess_ratio * particles, when particles join, or when KLD-sampling wants a count outside [n / 2, n].
  std::size_t resample_interval = 1;
  double resample_ess_ratio = 0.5;
  EndpointModel sensor = filter_sensor_model();  // sigma_hit, z_hit, z_rand, max_range, weight_exponent
  // Scan points in unknown space count as if they lay at the map's truncation distance from a surface (like points in
  // observed free space) instead of as misses: a map leaves unknown what its mapping run did not see.
  bool unknown_as_free = true;
  // Adaptive tempering: log-likelihoods scaled down until min_ess_ratio * particles stay effective. 0 = off.
  double min_ess_ratio = 0.1;
  SubsetFirstOptions subset_first;
  MotionParameters motion;
  double update_min_d = 0.1;  // m
  double update_min_a = 0.1;  // rad
  RougheningOptions roughening;
  RecoveryOptions recovery;
  PlaceOptions places;
  SamePlace same_place;
  LedgerOptions ledger;
  StateOptions states;
  GlobalInitOptions global_init;
  GlobalSearchOptions global_search;
  LocalInitSpread local_init;
  PoseEstimateOptions estimate;
  std::uint64_t seed = 0;

  void validate() const;  // throws Error naming the parameter
};

}  // namespace tsdf_mcl
