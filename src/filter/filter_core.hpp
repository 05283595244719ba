#pragma once
// ParticleFilter's state and stages, private to the filter layer. One update (particle_filter.cpp) runs the stages in
// order; each file holds one of them:
//   filter_motion.cpp      motion gate, motion update, sensor update, tempering, the belief's fit
//   filter_search.cpp      global search: the first scan's hypotheses screened, the best kept and climbed
//   filter_own_points.cpp  places weighed on their own points (and their heights on the scan's rays)
//   filter_places.cpp      places: modes refined onto the map, the evidence between them, their shares
//   filter_decision.cpp    the ledger's turn (the track against its rivals), recovery, the state
//   filter_resampling.cpp  what joins the next generation, resampling per place
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "tsdf_mcl/filter/global_proposal.hpp"
#include "tsdf_mcl/filter/kld_sampling.hpp"
#include "tsdf_mcl/filter/motion_prediction.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/filter/place_ledger.hpp"
#include "tsdf_mcl/filter/recovery.hpp"
#include "tsdf_mcl/filter/resampling.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"
#include "tsdf_mcl/filter/track_state_machine.hpp"

namespace tsdf_mcl {

// How far the belief has come since the last initialization (or wrong lock found out); only ever moves forward, but
// a wrong lock takes it back to kConcentrated.
enum class Phase {
  kSearching,     // a global search: the belief spread over its modes
  kPlacesNamed,   // compact places hold converged_weight of the belief
  kConcentrated,  // the dominant place has held the belief, concentrated
  kConverged,     // the filter has converged: the ledger holds the track against challengers
};

class ParticleFilter::Core {
 public:
  Core(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params, std::size_t points_hint);

  void initialize_global();
  void initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras);
  void initialize_local(const Pose& pose, const LocalInitSpread& spread);
  FilterStep update(double time, const std::vector<Eigen::Vector3f>& points, const std::optional<Pose>& odometry,
                    const ScanExtras& extras);
  void request_update() { force_update_ = true; }

  bool initialized() const { return initialized_; }
  std::size_t particle_count() const { return count_; }
  const PoseEstimate& estimate() const { return estimate_; }
  TrackState state() const { return states_.state(); }
  const FilterParameters& params() const { return params_; }
  ParticleArrays particles() const { return evaluator_.particles(); }
  std::vector<double> particle_weights() const;
  std::size_t free_space_voxels();
  const std::vector<GravityCandidate>& gravity_candidates() { return proposal().candidates(); }

 private:
  GlobalProposal& proposal();
  void start(std::size_t count);
  bool converged_once() const { return phase_ >= Phase::kConverged; }
  bool concentrated_once() const { return phase_ >= Phase::kConcentrated; }

  // filter_motion.cpp: the motion gate, the motion model, the sensor update, tempering.
  bool calls_for_update(const Pose& delta, double time);
  FilterStep held_scan(const Pose& delta, double started_ms);
  void predict(std::size_t n, const Pose& delta, double dt);
  WeightSummary weigh_scan(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  void read_walls(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras);
  void temper(std::size_t n, FilterStep& step);
  double belief_fit(std::size_t n, const WeightSummary& summary, std::size_t points) const;
  WallTilt walls_at(const Pose& pose);

  // filter_search.cpp: global search.
  void search(std::size_t candidates, std::size_t keep, const std::vector<Eigen::Vector3f>& points,
              const ParticleArrays& dst, std::size_t offset);
  void reserve_search(std::size_t candidates);
  void climb(std::size_t n, const std::vector<Eigen::Vector3f>& points);
  EndpointModel screening_model() const;

  // filter_own_points.cpp: unknown is unknown within each place (docs/filter.md).
  void weigh_own_points(std::size_t n, const std::vector<Eigen::Vector3f>& points, const Pose& delta, FilterStep& step);
  std::vector<Pose> own_point_centres(const Pose& delta, double reach) const;
  bool weigh_place_on_own_points(std::size_t n, std::size_t c, const Pose& centre,
                                 const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  void weigh_height_on_rays(const Pose& centre, const std::vector<Eigen::Vector3f>& points, const RayFit& centre_fit,
                            double below_coverage);
  double coverage_below_horizon(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
                                const std::vector<std::uint8_t>& observed);
  void weigh_within_places(std::size_t n, double beta);

  // filter_places.cpp: the places of the belief and their shares.
  void weigh_places(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  struct PlaceFits;
  PlaceFits fit_places(std::size_t n, const std::vector<Eigen::Vector3f>& points);
  std::vector<double> place_nats(std::size_t n, PlaceFits& fits, const std::vector<Eigen::Vector3f>& points,
                                 const FilterStep& step);
  void even_places_as_named(std::size_t n, const PlaceFits& fits, std::vector<double>& nats);
  void turn_on_decisive_views(std::size_t n, const PlaceFits& fits, const std::vector<double>& evidence,
                              std::vector<double>& nats);
  void take_shares(std::size_t n, const PlaceFits& fits, FilterStep& step);
  void keep_estimate_place(const FilterStep& step);
  bool at_frontier(const RayFit& fit, const Pose& pose) const;
  bool at_frontier_of(const RayFit& fit, const Pose& pose) const;
  double rest_evidence(std::size_t n, std::size_t groups, double points);
  void rank_places(std::size_t n, std::vector<Place>& places, std::int32_t rest_group);
  double evidence_dead_band() const;
  float frontier_reach() const;

  // filter_decision.cpp: recovery, the ledger, the state.
  void judge_belief(std::size_t n, const std::vector<Eigen::Vector3f>& points, const WeightSummary& summary,
                    FilterStep& step);
  double judge_fit(FilterStep& step);
  void follow_track(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  std::vector<Pose> rivals_to_judge(const std::vector<Eigen::Vector3f>& points);
  std::vector<Pose> fittest_elsewhere(const std::vector<Eigen::Vector3f>& points);
  void hold_track(const Pose& continuation, const RayFit& fit, const Pose& delta, double dt);
  void plan_restore(const PlaceLedger::Outcome& outcome);
  PlaceLedger::Verdict judge_places(const Pose& track, const Pose& place, const std::vector<Eigen::Vector3f>& points);
  void decide_state(FilterStep& step);
  void restart_after_wrong_lock();
  bool trusted_track() const { return states_.holds_track(); }
  bool map_judges_track() const;
  double judged_ratio() const;

  // filter_resampling.cpp: the next generation.
  struct Injection {
    std::size_t count = 0;
    std::size_t candidates = 0;  // screened down to `count` from this many; count = drawn as they come
    double share = 0.0;          // of the belief, all of them together
    std::optional<Pose> around;  // drawn near this pose (a place the ledger favours), not from the proposal
  };
  struct GroupCounts {
    std::vector<std::size_t> counts;  // per place, the last entry the rest's
    double rest_share = 0.0;          // the rest's share of the belief, with the places too light to keep
    std::size_t kept = 0;             // all counts together, at most `room`
  };
  void resample_policy(double time, std::size_t n, const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras,
                       FilterStep& step);
  Injection plan_injection(double time, const FilterStep& step) const;
  void resample(std::size_t n, std::size_t budget, const Injection& injection,
                const std::vector<Eigen::Vector3f>& points, FilterStep& step);
  GroupCounts count_groups(std::size_t n, std::size_t budget, std::size_t room);
  void inject(const Injection& injection, std::size_t injected, const std::vector<Eigen::Vector3f>& points,
              const ParticleArrays& dst, std::size_t offset);
  void set_prior_weights(const GroupCounts& plan, std::size_t injected, double injection_share);

  const TsdfMap& map_;
  SensorEvaluator& evaluator_;
  FilterParameters params_;
  std::unique_ptr<GlobalProposal> proposal_;

  // The particle set (the MCL core).
  std::size_t capacity_ = 0;
  std::size_t points_capacity_ = 0;
  std::size_t count_ = 0;
  bool initialized_ = false;
  std::uint64_t step_ = 0;  // filter updates so far: part of every random stream's name
  std::size_t updates_since_resample_ = 0;
  std::size_t injected_begin_ = 0;  // particles [injected_begin_, injected_end_) came from recovery
  std::size_t injected_end_ = 0;
  std::vector<double> prior_log_weight_;  // carried between updates that do not resample
  std::vector<double> post_log_weight_;   // this update's: prior + tempered likelihood, shifted per place
  std::vector<double> weights_;           // exp(post - max)
  std::vector<std::uint32_t> ancestors_;
  KldSampler kld_;
  GroupResampler group_resampler_;
  SubsetFirstWeighing subset_first_;
  MotionPrediction motion_;
  bool force_update_ = false;
  RecoveryMonitor recovery_;
  std::size_t implausible_streak_ = 0;
  double implausible_share_ = 0.0;  // this update's: the share a wrong lock sends to a new search (0: none)
  double last_challenge_time_ = -1e300;
  bool challengers_weighed_ = false;  // a background search's particles have been through an update
  // The last resampling brought particles from the proposal (challengers, recovery): the next update weighs them, and
  // the ledger looks for places among them.
  bool fresh_particles_weighed_ = false;

  // What the belief has come to.
  Phase phase_ = Phase::kSearching;
  bool local_start_ = false;            // initialized at a given pose, no wrong lock found out since
  std::size_t covered_streak_ = 0;      // updates in a row whose dominant place the map covered (most of the scan)
  bool mapped_track_ = false;           // covered_streak_ reached mapped_track_updates since the (re)start
  bool dominant_concentrated_ = false;  // the last update's dominant place held the belief, concentrated

  // This update's scan and motion.
  const std::vector<Eigen::Vector3f>* scan_ = nullptr;  // the points of the update running (for the ledger)
  Pose update_delta_ = Pose::Identity();
  std::optional<Pose> track_prediction_;       // where the odometry carries the held track (after convergence)
  std::optional<Pose> estimate_prediction_;    // where it carries the last reported estimate, once there is one
  std::vector<Eigen::Vector3f> scan_normals_;  // planar patches (sensor frame), for WallTilt
  std::size_t scan_points_ = 0;

  // The places (modes) of the belief.
  PoseEstimator estimator_;
  PoseEstimate estimate_;
  std::vector<std::int32_t> group_;                     // place of each particle; places.size() = the rest
  std::vector<double> group_share_;                     // share of each group after the evidence between places
  std::vector<std::pair<Pose, Pose>> decisive_before_;  // the last update's decisive verdicts (best, beaten)

  // Places weighed on their own points (filter_own_points.cpp) and the ledger's search elsewhere: scratch that only
  // grows.
  std::vector<Eigen::Vector3f> own_points_;
  std::vector<std::uint8_t> own_observed_;
  std::vector<double> own_log_weight_;      // each place's particles on its own points (then posteriors)
  std::vector<std::int32_t> own_place_of_;  // each particle's place (own_point_centres' index), -1: none
  std::vector<std::uint32_t> members_;
  std::vector<std::uint32_t> elsewhere_;
  std::size_t own_places_ = 0;  // places [0, this) hold particles weighed on their own points

  // The decision.
  PlaceLedger ledger_;
  bool rivals_undecided_ = false;  // this update's ledger: rivals followed
  bool rival_proven_ = false;      // ... one of them proven better than the track
  TrackStateMachine states_;
  Matrix6d track_covariance_ = Matrix6d::Zero();
  struct Restore {
    Pose place;
    double share = 0.0;
  };
  std::optional<Restore> restore_;  // the next resampling puts particles there with this share of the belief
  // judge_places' track side, kept for the update's other places.
  struct JudgedTrack {
    std::uint64_t step = ~std::uint64_t{0};
    Pose pose = Pose::Identity();
    PointEvidence evidence;
  };
  JudgedTrack judged_;
  Pose last_estimate_pose_ = Pose::Identity();
  bool estimate_placed_ = false;  // last_estimate_pose_ is an estimate (an update's or the local start's)
};

}  // namespace tsdf_mcl
