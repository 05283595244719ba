#pragma once
// The 6-DoF particle filter: motion update on the host, sensor update by a SensorEvaluator (GPU or CPU),
// resampling with KLD-adapted particle counts and recovery by random particles, all on the evaluator's
// particle buffers in place.
//
// One update():
//   motion gate (update_min_d / update_min_a on the motion since the last filter update; also a time
//   interval until the first convergence) -> motion update (+ roughening until the first convergence)
//   -> sensor update (evaluator) -> tempering -> hypotheses (modes) and the evidence between them
//   -> fit of each hypothesis, recovery, convergence -> resampling per hypothesis when due.
// Scans the gate holds back move only the estimate (by the motion since the last update), not the particles:
// noise that grows with the motion must be drawn once for the whole motion, not once per small step.
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "tsdf_mcl/filter/convergence.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/filter/global_proposal.hpp"
#include "tsdf_mcl/filter/kld_sampling.hpp"
#include "tsdf_mcl/filter/look_alikes.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/motion_prediction.hpp"
#include "tsdf_mcl/filter/particle_init.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/filter/recovery.hpp"
#include "tsdf_mcl/filter/resampling.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"
#include "tsdf_mcl/filter/track_keeper.hpp"
#include "tsdf_mcl/filter/track_state.hpp"

namespace tsdf_mcl {

// The endpoint model with the filter's default tempering, weight_exponent 0.2. Neighbouring beams and
// successive scans see the same surfaces with the same map errors, so the untempered product of 500 points per
// scan, one scan per 0.1 m, collapses a global belief within a metre of travel onto whichever of two look-alike
// rooms a particle happened to fit best. Measured on the simulated office's 10 test routes: 9 converge with
// 0.2, 8 with 1 (docs/filter.md).
inline EndpointModel filter_sensor_model() {
  EndpointModel m;
  m.weight_exponent = 0.2f;
  return m;
}

// Global localization from a scan: a large set of hypotheses from the proposal (global_proposal.hpp), each
// scored on a few points of the scan with a wide likelihood, the best kept as the initial particles. Scoring
// a million hypotheses on 64 points costs what 125,000 particles cost on 512, and covers the map eight times
// as densely. The wide sigma (about the map's truncation) lets a hypothesis a few decimetres or degrees off
// still score: the narrow one would rank it with the wrong places.
struct GlobalSearchOptions {
  std::size_t candidates = 1000000;  // hypotheses scored (fewer than the initial particles: no screening)
  std::size_t screen_points = 64;    // points of the scan they are scored on
  float screen_sigma = 0.3f;         // m
  // Then every kept hypothesis climbs: per round, three jittered copies (0.1 m / 1.7° in the first round, half
  // that in the second) scored on twice the points, and it moves to the best of the four. Each hypothesis
  // climbs on its own, so a look-alike keeps its place beside the right one while both get aligned.
  std::size_t climb_rounds = 2;
  ProposalOptions proposal;

  void validate() const;  // throws Error naming the parameter
};

// What the global search may use of a scan besides the points of the sensor update.
struct ScanExtras {
  const std::vector<Eigen::Vector3f>* dense = nullptr;  // the scan before thinning (sensor frame)
  std::optional<Eigen::Vector3f> imu_up;                // gravity from an IMU: up in the sensor frame
};

struct FilterParameters {
  std::size_t initial_particles = 100000;  // particles of a global or local initialization
  KldParameters kld;                       // min_particles, max_particles, pf_err, pf_z, bins
  ResamplingMethod resample_method = ResamplingMethod::kSystematic;
  // Resampling is considered every resample_interval-th update, and done when the effective sample size is
  // below resample_ess_ratio * particles, when recovery injects particles, or when KLD-sampling wants a
  // particle count outside [particles / 2, particles] (the count only changes by resampling).
  std::size_t resample_interval = 1;
  double resample_ess_ratio = 0.5;
  // Recovery (augmented MCL): round(share * max_particles) particles from the proposal join the next
  // generation, carrying `share` of the belief, with share = 1 - w_fast / (w_slow (1 - recovery_margin)) clamped
  // to [0, 1] (see recovery.hpp). The count scales with max_particles, not with the current count, so a lost
  // track's hypotheses cover the map; the weight they carry follows the evidence, so a brief dip moves little of
  // the belief. The fit averaged is the dominant hypothesis's inlier ratio (scan_fit.hpp), from the first
  // convergence on. Both alphas 0 = off.
  double recovery_alpha_slow = 0.02;
  double recovery_alpha_fast = 0.1;
  double recovery_margin = 0.3;
  // sigma_hit, z_hit, z_rand, max_range (= laser_max_range), weight_exponent (0.2: filter_sensor_model).
  EndpointModel sensor = filter_sensor_model();
  // Scan points in unknown space count as if they lay at the map's truncation distance from a surface, like
  // points in observed free space (sensor.unknown_distance is set from the map), instead of as misses (p_rand).
  // A map leaves unknown what its mapping run did not see: the ceiling above a drone flying higher than the
  // mapping robot drove, a room seen through its door only. As misses, those points cost the true pose more
  // than a look-alike's points in free space cost it, and the look-alike won (the simulated office, handheld and
  // drone runs on a ground robot's map, docs/filter.md).
  bool unknown_as_free = true;
  // Adaptive tempering: if the weights of an update would leave fewer than min_ess_ratio * particles
  // effective particles (particles injected by recovery in the last resampling not counted), its
  // log-likelihoods are scaled down until they do not. Keeps a peaky likelihood from collapsing the set onto a
  // few lucky particles. 0 = off.
  double min_ess_ratio = 0.1;
  // Subset first (subset_first.hpp): sets of at least subset_first.min_particles are weighed on
  // subset_first.points of the scan first, and only the best subset_first.share on the whole scan.
  SubsetFirstOptions subset_first;
  MotionParameters motion;
  double update_min_d = 0.1;  // m
  double update_min_a = 0.1;  // rad
  // Until the filter first converges after an initialization, every update adds a random walk of these
  // standard deviations per axis on top of the motion noise (not while the dominant hypothesis holds the belief,
  // concentrated: docs/filter.md, the drone's height), and a scan the motion gate would hold is still an
  // update once roughening_interval has passed since the last one. A global belief is sparse: its particles
  // nearest the true pose are typically decimetres and degrees off, where the likelihood of hundreds of points
  // cannot tell them from a wrong place. Roughening lets them climb the likelihood over a few scans before
  // selection judges them, also while the robot stands still. The interval keeps a fast sensor (20 Hz) from
  // judging the same view again and again, which locks onto a wrong place in a symmetric building.
  // 0 = off.
  double roughening_xyz = 0.1;       // m
  double roughening_angle = 0.04;    // rad
  double roughening_interval = 1.0;  // s
  // Hypotheses (hypothesis_weighting.hpp): between modes of the belief a scan is worth this many independent
  // points of evidence (fewer while the tempering counts it as fewer), each point's evidence its log-likelihood
  // at the mode's mean pose refined onto the map (scan_fit.hpp). Each of the heaviest modes
  // (PoseEstimateOptions::max_hypotheses) holding at least hypothesis_min_weight of the belief keeps at least
  // hypothesis_min_particles particles through resampling, whatever its share: a look-alike room is not lost to
  // resampling noise before a view tells the rooms apart. 64 of 512 points: between places only the points beyond
  // the dead band, observed at both, count (scan_fit.hpp: paired_evidence), which keeps most of identical rooms'
  // residue out of the sum; a staircase seen from afar (5-15 of the 512 points) turned a concentrated belief 2-4
  // scans after its first sight, 5-11 at 16 (docs/filter.md, "A scan between places counts as 64 points"). The
  // look-alike memory (look_alikes.hpp) sums its evidence in the same units.
  double hypothesis_evidence_points = 64.0;
  // Before the belief first concentrates, a decisive view still turns it: against a place that the best-judged one
  // beats decisively on two updates in a row, a scan counts as up to hypothesis_evidence_points, as far as it turns
  // the two places' odds to estimate_switch_ratio squared (the estimate follows) and no further
  // (hypothesis_weighting.hpp: decisively_beaten, turn_odds). Decisive: both places compact, the map covering nearly
  // all of the scan at both, and the best-judged place explaining at least this much more of its observed points
  // (inlier ratio), so that the paired evidence and the raw fit agree. With the tempering's count alone a two-storey
  // run turned 48 scans after the staircase came into view (24 with this). Counted in full with no cap, a view before
  // the staircase concentrated a belief, and the look-alike memory then proved the wrong storey on the map's residue;
  // on single updates, a place's refined pose that landed off turned the estimate (docs/filter.md, "A decisive view
  // turns the estimate"). 0 = off.
  double decisive_inlier_gap = 0.03;
  // As a global search first names its places (until compact places hold converged_weight of the belief), places
  // tied with the best fit (within decisive_inlier_gap) start with equal shares, whatever the particles held there
  // (hypothesis_weighting.hpp: even_tied_places). A handful of the uniform start's guesses land near each of two
  // identical places, and a 2 : 1 split between the symmetric building's wings stood until a landmark came into view,
  // which then needed 12-18 scans to turn it. Measured off by default at first: where the units differ in what the map
  // never observed (a room the mapping run skipped), levelled places lost right tracks to the skipped room's mapped
  // twin as its door came into view; since a pair waits there (hypothesis_weighting.hpp: waiting_pairs) they do not
  // (docs/filter.md, "A door waits, a place that fits worse is refined again, tied places start equal"). false: the
  // particles' split (--sampled_place_shares).
  bool even_tied_places = true;
  // Points at the frontier of the map's observed space (within a truncation length of space it never observed,
  // scan_fit.hpp: drop_frontier_points) are no evidence between places, nor between the particles of a concentrated
  // cloud (weigh_track_on_evidence), unless this is set.
  bool frontier_evidence = false;
  // A place weighed on its own points (weigh_track_on_evidence) also weighs its particles' heights on the scan's rays,
  // where the map holds most of what the sensor sees below its horizon: a ray that passes into a surface of the map
  // well before its end costs this many times what a point far from every surface costs against one on a surface
  // (0 = off). Where the map holds the walls only up to a band, the points cannot tell a pose 0.35 m low from the
  // truth; the rays can (docs/filter.md, "Why the avz handheld's height stayed low").
  double see_through_weight = 1.0;
  std::size_t hypothesis_min_particles = 200;
  double hypothesis_min_weight = 1e-5;
  // A scan point is an inlier (scan_fit.hpp) within this distance of a surface (m).
  float inlier_distance = 0.2f;
  // The scan's walls hold the tilt of every pose refined onto the map (scan_fit.hpp: WallTilt), each planar patch
  // within 10° of vertical weighing this much against 512 points (0: the points alone), in proportion to the points
  // (the points' weight in the refinement grows with their count, the scan's information does not). In a room whose
  // upper walls the map never observed, the points hardly fix the tilt, and a cloud 2° off stayed there; 3 held it
  // (docs/filter.md). With the walls on, a drone above a map's mapped band (ChangedMap.*KeepsItsHeight) sank at some
  // weights and builds until the track kept its height by its own points (kTrackRadius, local_start_, the rest's
  // evidence at the frontier): now at most 2 of its 34 poses at any weight 0-8, in either build.
  double wall_tilt_information = 3.0;
  ConvergenceOptions convergence;
  // Recovery from an implausible fit: once the belief has concentrated, a dominant hypothesis whose inlier
  // ratio stays below this for two updates is a wrong lock however steady its fit: a share 1 - ratio / this
  // of the next generation comes from the proposal (screened on the scan) and the filter searches again.
  // 0 = off.
  double recovery_min_inliers = 0.3;
  // Challengers (a background global search, once the belief has concentrated): every challenger_interval
  // seconds, challenger_candidates hypotheses from the proposal are screened on the scan and the best
  // 1/200 of them join the belief with a share of converged_competitor_weight / 10 together, and the particles outside
  // the heaviest hypotheses keep at least that many places through resampling: a pool that keeps searching.
  // A place that explains the scans better than the track gains share by the evidence and becomes a
  // hypothesis (a competitor, then the track); where the track is right they fit worse and stay negligible.
  // This is what lets a filter leave a wrong lock whose fit looks plausible. 0 candidates = off.
  std::size_t challenger_candidates = 20000;
  double challenger_interval = 0.5;  // s
  // A jump needs proof (track_keeper.hpp): once converged, the track is only left for a challenger that explains
  // the scans better over track.proof_travel_m of travel, judged on the points observed under both poses.
  TrackKeeperOptions track;
  // Look-alikes (look_alikes.hpp): a place elsewhere that the scans since it was found have not refuted holds
  // `converged` back, whatever its share of the belief.
  LookAlikeOptions look_alikes;
  // TrackState::kAmbiguous also when the second hypothesis holds at least this share of the belief.
  double ambiguous_weight = 0.1;
  // While no place dominates, the estimate stays on the odometry continuation of the place it reported until
  // another place holds this many times that place's share: a near-tie between look-alikes (the symmetric
  // building's wings at 0.505 / 0.495) does not move it 18 m and back. 1 = always the heaviest place.
  double estimate_switch_ratio = 1.2;
  GlobalInitOptions global_init;
  GlobalSearchOptions global_search;
  LocalInitSpread local_init;
  PoseEstimateOptions estimate;
  std::uint64_t seed = 0;

  void validate() const;  // throws Error naming the parameter
};

struct StepTimings {
  double motion_ms = 0.0;
  double upload_ms = 0.0;      // scan points into the evaluator
  double weight_ms = 0.0;      // evaluator: weighting + reduction, host wall time
  double weight_gpu_ms = 0.0;  // GPU timestamps (NaN without)
  double reduce_gpu_ms = 0.0;
  double reduce_ms = 0.0;      // host: tempering, hypotheses, recovery averages, decision; of which
  double tempering_ms = 0.0;   //   the adaptive tempering (tempering.hpp)
  double hypotheses_ms = 0.0;  //   the pose estimate's modes, each refined onto the map, and their evidence
  double walls_ms = 0.0;       // the scan's planar patches, whose walls hold the refined tilt
  double resample_ms = 0.0;    // KLD count, resampling, injection
  double total_ms = 0.0;
};

struct FilterStep {
  bool updated = false;  // false: the motion gate held this scan back; only the estimate moved
  bool resampled = false;
  std::size_t particles = 0;       // particles weighted in this update
  std::size_t next_particles = 0;  // after resampling
  std::size_t kld_bins = 0;        // bins occupied by the weighted set (when resampled)
  std::size_t injected = 0;        // random particles from recovery
  std::size_t points = 0;
  std::size_t weighed_points = 0;  // of them, the first place weighed on its own (the track's) took these (0: all)
  double ess = 0.0;                // effective sample size after tempering
  double tempering = 1.0;          // the adaptive factor applied to the log-likelihoods
  double fit = 0.0;                // mean per-point geometric-mean likelihood over particles (diagnostic)
  double w_slow = 0.0;
  double w_fast = 0.0;
  double random_share = 0.0;            // share of the next generation from the proposal (recovery)
  bool concentrated = false;            // the dominant hypothesis holds converged_weight and is compact
  bool implausible = false;             // ... and its inlier ratio is below recovery_min_inliers
  bool challenged = false;              // another hypothesis explains the scan nearly as well (convergence.hpp)
  std::vector<Pose> look_alikes;        // places the scans have not told from the track (look_alikes.hpp)
  std::size_t challengers = 0;          // particles of the background search added in this update
  std::size_t restored = 0;             // particles put back on the track after a disproven challenger
  std::size_t look_alike_restored = 0;  // particles put at a look-alike the scans proved better (look_alikes.hpp)
  // The published estimate stays on the track against a dominant hypothesis elsewhere that is not proven yet
  // (track_keeper.hpp); the challenge's paired evidence (nats) and travel (m) so far.
  bool holding = false;
  double challenge_evidence = 0.0;
  double challenge_travel = 0.0;
  TrackState state = TrackState::kSearching;  // what the filter can say about its track (track_state.hpp)
  StepTimings timings;
  PoseEstimate estimate;
};

class ParticleFilter {
 public:
  // Reserves the evaluator's buffers for max(initial, max) particles and `points_hint` points up front; the
  // map and the evaluator must outlive the filter.
  ParticleFilter(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                 std::size_t points_hint = 512);
  // Not copied: its look-alike memory judges places through this filter (a copy would judge through the original).
  ParticleFilter(const ParticleFilter&) = delete;
  ParticleFilter& operator=(const ParticleFilter&) = delete;

  // Uniform over the map's free space (within the tilt and height priors of global_init), no scan needed.
  void initialize_global();
  // Global search guided by the first scan (GlobalSearchOptions): `points` as for update(), `extras.dense`
  // the same scan before thinning, for its up direction and floor height.
  void initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras);
  void initialize_local(const Pose& world_T_sensor);
  // ... with another spread than params().local_init (an initial pose given with its covariance).
  void initialize_local(const Pose& world_T_sensor, const LocalInitSpread& spread);

  // One scan: `points` in the sensor frame (preprocessed, non-empty, finite); `odometry` = odom_T_sensor
  // at the scan (required by the odometry motion model, ignored otherwise). `extras` guide recovery's
  // hypotheses like a global search's.
  FilterStep update(double time, const std::vector<Eigen::Vector3f>& points, const std::optional<Pose>& odometry,
                    const ScanExtras& extras = {});

  // The next update() weighs the scan even if the motion gate would hold it (nav2's request_nomotion_update).
  void request_update() { force_update_ = true; }

  bool initialized() const { return initialized_; }
  std::size_t particle_count() const { return count_; }
  const PoseEstimate& estimate() const { return estimate_; }
  TrackState state() const { return state_; }  // of the last scan (track_state.hpp)
  const FilterParameters& params() const { return params_; }
  // The active particle set (views stay valid until the next update or initialization).
  ParticleArrays particles() const { return evaluator_.particles(); }
  // The active particles' weights, normalized (uniform right after resampling).
  std::vector<double> particle_weights() const;
  // Number of free-space voxels global initialization and recovery sample from (builds the table).
  std::size_t free_space_voxels();
  // The gravity and height candidates of the last global search or recovery (empty: uniform).
  const std::vector<GravityCandidate>& gravity_candidates() { return proposal().candidates(); }

 private:
  GlobalProposal& proposal();
  void start(std::size_t count);
  // The stages of update(), in order.
  // Motion gate: whether the motion since the last update (or a request) calls for a sensor update.
  bool calls_for_update(const Pose& delta, double time);
  // Motion model: every particle moves by `delta` with its noise, roughened until the first convergence.
  void predict(std::size_t n, const Pose& delta, double dt);
  // Sensor update: the scan's likelihood of every particle (subset first where configured).
  WeightSummary weigh_scan(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  // Unknown is unknown within each place (once there is a track: a few hypotheses that pass the convergence test's
  // spread, and the kept track's predicted pose): a place's particles (those near its predicted pose) are weighed
  // against each other on the points that land, at that pose, clear of space the map never observed and of its frontier
  // (drop_frontier_points), so none gains by pushing the scan out of the unobserved band (a drone whose map's walls
  // end where the mapping robot's view did sank towards the floor). Each place's total against the others stays the
  // whole scan's (and so do the tempering, recovery's fit and the hypotheses' evidence): the points a place never
  // observed are evidence against a look-alike that did. Sets step.weighed_points (0 where the whole scan weighs
  // every particle).
  void weigh_track_on_evidence(std::size_t n, const std::vector<Eigen::Vector3f>& points, const Pose& delta,
                               FilterStep& step);
  // Adds each member of the place at `centre` (members_) its height's see-through cost to evidence_log_weight_
  // (see_through_weight); `centre_fit` is ray_fit at the centre itself, `below_coverage` the share of the points
  // below the sensor's horizon there with map evidence (`observed`: ray_fit's flags).
  void weigh_height_on_rays(const Pose& centre, const std::vector<Eigen::Vector3f>& points, const RayFit& centre_fit,
                            double below_coverage);
  double coverage_below_horizon(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
                                const std::vector<std::uint8_t>& observed);
  // The predicted poses of the places weigh_track_on_evidence weighs on their own points (none before there is a
  // track to keep, or while the belief is spread; a local start's given pose is one from the start).
  std::vector<Pose> evidence_centres(const Pose& delta, double reach) const;
  // Evidence: tempered weights, the hypotheses and their paired evidence, the fit recovery follows and the
  // implausible-fit test; returns the share of the next generation a wrong lock sends to a new search (0: none).
  double weigh_evidence(std::size_t n, const std::vector<Eigen::Vector3f>& points, const WeightSummary& summary,
                        FilterStep& step);
  // Decision: the track keeper's turn, convergence, the track's trust, a wrong lock's restart, the state.
  void decide(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points, double implausible_share,
              FilterStep& step);
  // Resampling policy: when to resample (interval, depletion, KLD size) and what joins (recovery, challengers).
  void resample_policy(double time, std::size_t n, const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras,
                       FilterStep& step);
  void prepare_weights(std::size_t n, FilterStep& step);
  // Each place's particles' posterior log-weights from its evidence points (weigh_track_on_evidence), tempered by
  // `beta` like the whole scan's, the place's log-sum-exp kept; then weights_ again.
  void weigh_track_within(std::size_t n, double beta);
  // The modes as hypotheses, each refined onto the map and weighed against the best-fitting one on the points
  // both observe (the between-hypothesis evidence moves the groups' shares); then ranked by their shares.
  void weigh_hypotheses(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  // Evens `nats` between the places tied with the best fit (FilterParameters::even_tied_places) until the places are
  // named: compact places holding converged_weight of the belief.
  void even_places_as_named(std::size_t n, const std::vector<Hypothesis>& h, const std::vector<RayFit>& fit,
                            const std::vector<bool>& waits, std::vector<double>& nats);
  // Turns `nats` (weigh_hypotheses: each place's evidence, then the rest's) against the places beaten decisively on
  // this update and the last (FilterParameters::decisive_inlier_gap), before the belief first concentrates.
  void turn_on_decisive_views(std::size_t n, const std::vector<Hypothesis>& h, const std::vector<Pose>& poses,
                              const std::vector<RayFit>& fit, const std::vector<double>& evidence,
                              const std::vector<bool>& waits, std::vector<double>& nats);
  // The estimate from the place it reported last, where the heaviest place does not hold estimate_switch_ratio
  // times its share.
  void keep_estimate_place(const FilterStep& step);
  // A place at the frontier of unmapped space, whose evidence waits (weigh_hypotheses): after a mapped track, the
  // map covers less than most of its scan, and it fits its observed points well or continues the kept track.
  bool at_frontier(const RayFit& fit, const Pose& pose) const;
  bool at_frontier_of(const RayFit& fit, const Pose& pose) const;  // at_frontier without the coverage test
  // The rest group's (particles in no hypothesis) evidence per point: their marginal likelihood; NaN without any.
  double rest_evidence(std::size_t n, std::size_t groups, double points);
  // Hypotheses and groups renumbered by share, best first; the top place's point log-likelihoods and map evidence
  // (taken from `point_log` and `observed`, one per hypothesis) kept for the track keeper.
  void rank_hypotheses(std::size_t n, std::vector<Hypothesis>& h, std::vector<std::vector<double>>& point_log,
                       std::vector<std::vector<std::uint8_t>>& observed, std::int32_t rest_group);
  double belief_fit(std::size_t n, const WeightSummary& summary, std::size_t points) const;
  double judge_fit(FilterStep& step);
  // The track keeper's turn (track_keeper.hpp) after the convergence test: may move the estimate back onto the
  // track and schedule particles for it.
  void keep_track(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  // The look-alike memory's turn (look_alikes.hpp) on the dominant hypothesis and the others: step.look_alikes.
  void remember_look_alikes(const Pose& delta, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  // The look-alike memory's judge: paired evidence of pose `a` over `b` on `points` (nats, in the units the hypotheses'
  // shares move by) and the share of the scan each explains.
  LookAlikeMemory::Verdict judge_places(const Pose& a, const Pose& b, const std::vector<Eigen::Vector3f>& points) const;
  // judge_places' track side, kept for the update's other places.
  struct JudgedTrack {
    std::uint64_t step = ~std::uint64_t{0};
    const Eigen::Vector3f* points = nullptr;
    Pose pose = Pose::Identity();
    PointEvidence evidence;
  };
  mutable JudgedTrack judged_;
  TrackState classify(const FilterStep& step) const;
  double evidence_dead_band() const;  // what a point inlier_distance off a surface loses (nats)
  // How far from unobserved space a point must land to be evidence between places (0: any observed point is).
  float frontier_reach() const;
  // A track that was converged at the last update where the map covered the scan: only such a track tracks
  // through unmapped space (its fit is judged on the observed points, and not at all where the map covers too
  // little). Any other belief is judged on the inlier share of all its points: a lost track that drifts out of
  // the map must not pass for one in an unmapped room.
  bool trusted_track() const { return keeper_.active() && trusted_; }
  // Whether the map covers enough of the scan at the estimate for the fit to judge a trusted track (recovery's
  // averages, the implausible-fit test, a lapse of `converged` ending the trust): most of it, not just
  // converged_min_coverage. Near a room the mapping run never entered, the points the map does observe lie on its
  // frontier, surfaces seen once at grazing angles through a door, and fit worse than the track is wrong.
  bool map_judges_track() const;
  double judged_ratio() const;
  // Particles from the proposal that join the next generation (recovery, challengers).
  struct Injection {
    std::size_t count = 0;
    std::size_t candidates = 0;  // screened down to `count` from this many; count = drawn as they come
    double share = 0.0;          // of the belief, all of them together
    std::optional<Pose> around;  // drawn near this pose (the track, a proven look-alike), not from the proposal
    bool look_alike = false;     // around a proven look-alike
  };
  Injection plan_injection(double time, const FilterStep& step) const;
  // The next generation: `budget` particles drawn per hypothesis (count_groups) and the injection's after them.
  void resample(std::size_t n, std::size_t budget, const Injection& injection,
                const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  // Particles per group of the next generation (the last group: the rest) and the share the rest carries.
  struct GroupCounts {
    std::vector<std::size_t> counts;
    double rest_share = 0.0;  // the rest's share of the belief, with the hypotheses too light to keep
    std::size_t kept = 0;     // all counts together, at most `room`
  };
  // Moves the particles of hypotheses too light to keep to the rest (group_).
  GroupCounts count_groups(std::size_t n, std::size_t budget, std::size_t room);
  // The injection's `injected` particles into dst[offset, offset + injected).
  void inject(const Injection& injection, std::size_t injected, const std::vector<Eigen::Vector3f>& points,
              const ParticleArrays& dst, std::size_t offset);
  // prior_log_weight_ of the next generation: the kept particles', then the injected ones'.
  void set_prior_weights(const GroupCounts& plan, std::size_t injected, double injection_share);
  // A screened search: `candidates` hypotheses from the proposal, block by block (global_proposal.hpp), each
  // block scored with a wide likelihood on the scan points that tell its hypotheses apart; the best `keep`,
  // shared between the blocks by their mixture weights, go to dst[offset, offset + keep). The active particle
  // set is the scratch space.
  void search(std::size_t candidates, std::size_t keep, const std::vector<Eigen::Vector3f>& points,
              const ParticleArrays& dst, std::size_t offset);
  // Grows the evaluator for the largest block such a search samples at once (invalidates particle views).
  void reserve_search(std::size_t candidates);
  // The kept hypotheses [0, n) of a global search climb the likelihood of `points` (GlobalSearchOptions).
  void climb(std::size_t n, const std::vector<Eigen::Vector3f>& points);

  const TsdfMap& map_;
  SensorEvaluator& evaluator_;
  FilterParameters params_;
  std::unique_ptr<GlobalProposal> proposal_;
  KldSampler kld_;
  PoseEstimator estimator_;
  RecoveryMonitor recovery_;
  ConvergenceMonitor convergence_;
  TrackKeeper keeper_;
  LookAlikeMemory look_alikes_;
  bool restore_pending_ = false;  // the next resampling puts particles back on the track
  // A look-alike of which the belief holds less than half the share its evidence gives it (remember_look_alikes: one
  // the memory proved better than the track, or any it keeps before the track first converged): the next resampling
  // puts particles there with this share of the belief.
  struct LookAlikeToRestore {
    Pose place;
    double share = 0.0;
  };
  std::optional<LookAlikeToRestore> look_alike_to_restore_;
  bool trusted_ = false;         // converged with enough map coverage, not lapsed where the map covers the scan
  bool track_followed_ = false;  // this update: the dominant hypothesis continues the kept track (keep_track)
  Matrix6d track_covariance_ = Matrix6d::Zero();
  GroupResampler group_resampler_;

  std::size_t capacity_ = 0;
  std::size_t points_capacity_ = 0;
  std::size_t count_ = 0;
  bool initialized_ = false;
  std::uint64_t step_ = 0;  // filter updates so far: part of every random stream's name
  std::size_t updates_since_resample_ = 0;
  std::size_t injected_begin_ = 0;  // particles [injected_begin_, injected_end_) came from recovery
  std::size_t injected_end_ = 0;
  bool ever_converged_ = false;     // since the last initialization or re-spread
  bool ever_concentrated_ = false;  // likewise
  bool places_named_ = false;       // likewise: compact places have held converged_weight of the belief
  bool local_start_ = false;        // initialized at a given pose (initialize_local), no wrong lock left since
  // Most of the scan: the map coverage at which the fit judges a place (map_judges_track, weigh_hypotheses).
  static constexpr double kMostOfTheScan = 0.75;
  // Nearly all of the scan: the map coverage at both places for a decisive view between them (weigh_hypotheses). In
  // the symmetric-skip runs, of the 58 updates where the mirror wing explained 0.02 more of the scan than the true
  // wing with most of the scan covered at both, 7 had this much at both (docs/filter.md, "A decisive view ...").
  static constexpr double kNearlyAllOfTheScan = 0.9;
  // A place lying mostly in unobserved space whose observed points fit at least this well is at the frontier of
  // unmapped space (weigh_hypotheses); measured: 0.83-0.95 in the skipped rooms of the matrix's *-skip scenes.
  static constexpr double kFrontierMinInliers = 0.8;
  // Once the places are named and until the belief first concentrates, a compact place whose refined pose explains
  // this much less of the scan than the best place's (inlier ratio) is refined again from its kRefineStarts heaviest
  // particles (weigh_hypotheses).
  static constexpr double kRefineAgainGap = 0.01;
  static constexpr std::size_t kRefineStarts = 8;
  // Between two places whose map coverage differs by this much, the less covered one's frontier is in view
  // (weigh_hypotheses). With the less covered place fitting as a frontier does, 49 of the 8,317 updates with two places
  // held such a gap in the symmetric and two-storey runs, 211 of the 2,034 in the symmetric-skip runs.
  static constexpr double kFrontierCoverageGap = 0.05;
  static constexpr std::size_t kMinEvidencePoints = 32;
  // m: particles this near a place's predicted pose belong to it (weigh_track_on_evidence). Four mode-finding cells
  // (PoseEstimateOptions::cluster_bin_xyz): at 1 m, particles 1.2-1.5 m below a drone's track above a map's mapped
  // band kept their whole-scan weights, which count its unobserved points as misses, joined its mode and spread it
  // past the compact test; the place was then weighed on the whole scan and sank (ChangedMap.*KeepsItsHeight).
  static constexpr double kTrackRadius = 2.0;
  static constexpr std::size_t kMaxEvidencePlaces = 4;  // places weighed on their own points, at most
  // Places outside the hypotheses, the scan's best-fitting particles, that the look-alike memory weighs each update.
  static constexpr std::size_t kFittestPlaces = 4;
  static constexpr std::size_t kMappedTrackUpdates = 10;  // updates in a row at a covered place: mapped_track_
  std::size_t covered_streak_ = 0;        // updates in a row whose top hypothesis the map covered (most of the scan)
  bool mapped_track_ = false;             // covered_streak_ reached kMappedTrackUpdates since the (re)start
  std::optional<Pose> track_prediction_;  // this update: where the odometry carries the kept track, if any
  // This update: where the odometry carries the last reported estimate, once there is one.
  std::optional<Pose> estimate_prediction_;
  Pose update_delta_ = Pose::Identity();  // this update's motion (odometry or IMU)
  // The last update's decisive verdicts (turn_on_decisive_views): the best-judged place's pose and the beaten one's.
  std::vector<std::pair<Pose, Pose>> decisive_before_;
  std::size_t implausible_streak_ = 0;
  double last_challenge_time_ = -1e300;
  bool challengers_weighed_ = false;  // a background search's particles have been through an update

  std::vector<Eigen::Vector3f> scan_normals_;  // this update's planar patches (sensor frame), for WallTilt
  std::size_t scan_points_ = 0;                // this update's points (the refinement's)
  // The scan's walls at `pose` (select_walls); no walls, no constraint.
  WallTilt walls_at(const Pose& pose);

  std::vector<double> prior_log_weight_;  // carried between updates that do not resample
  std::vector<double> post_log_weight_;   // this update's: prior + tempered likelihood, shifted per hypothesis
  std::vector<double> weights_;           // exp(post - max)
  std::vector<std::int32_t> group_;       // hypothesis of each particle; hypotheses.size() = none of them
  std::vector<double> group_share_;       // share of each group after the between-hypothesis tempering
  std::vector<std::uint32_t> ancestors_;
  SubsetFirstWeighing subset_first_;
  // The dominant hypothesis's per-point log-likelihoods and map evidence flags at its refined pose (this update).
  std::vector<double> top_log_;
  std::vector<std::uint8_t> top_observed_;
  std::vector<Eigen::Vector3f> evidence_points_;  // weigh_track_on_evidence's selection and its scratch
  std::vector<std::uint8_t> evidence_observed_;
  std::vector<double> evidence_log_weight_;  // each place's particles on its evidence points (then posteriors)
  std::vector<std::int32_t> place_of_;       // each particle's place (evidence_centres' index), -1: none
  std::vector<std::uint32_t> members_;       // one place's particles, gathered into the spare set
  std::vector<std::uint32_t> elsewhere_;     // particles outside the hypotheses (remember_look_alikes)
  std::size_t places_reweighed_ = 0;         // places [0, this) may hold particles weighed on their own points
  bool track_reweighed_ = false;             // this update weighed some place on its evidence points
  bool dominant_concentrated_ = false;       // the last update's dominant hypothesis held the belief, concentrated

  MotionPrediction motion_;  // the motion model's state between updates
  bool force_update_ = false;
  Pose last_estimate_pose_ = Pose::Identity();
  bool estimate_placed_ = false;  // last_estimate_pose_ is an estimate (an update's or the local start's)

  PoseEstimate estimate_;
  TrackState state_ = TrackState::kSearching;
};

}  // namespace tsdf_mcl
