// End-to-end filter tests on the synthetic office: global localization, tracking, kidnapping, KLD-sampling,
// the motion gate, determinism. CPU backend (deterministic and fast).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "filter_test_runs.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kScanPeriod = 0.5;  // s

using test::cpu_evaluator;

struct World {
  std::vector<test::Box> boxes = test::office_boxes();
  TsdfMap map = test::make_office_map();
  std::vector<Pose> truth = test::office_trajectory(120);
  std::vector<Pose> odometry = test::drifting_odometry(truth, 5);
  std::vector<std::vector<Eigen::Vector3f>> points;  // preprocessed scans
  World() {
    Rng rng(3);
    ScanPreprocessing o;
    o.max_beams = 256;
    ScanPreprocessor pre(o);
    for (std::size_t i = 0; i < truth.size(); ++i) {
      points.push_back(pre.process(test::simulate_scan(boxes, truth[i], rng), i));
    }
  }
};

const World& world() {
  static const World w;
  return w;
}

// A ground robot's prior knowledge: level sensor (gravity), 0.6-1.2 m above the floor.
FilterParameters ground_robot() {
  FilterParameters p;
  p.initial_particles = 20000;
  p.kld.max_particles = 20000;
  p.kld.min_particles = 300;
  p.global_init.max_tilt = 0.1;
  p.global_init.use_height_band = true;
  p.global_init.min_height = 0.6;
  p.global_init.max_height = 1.2;
  p.update_min_d = 0.0;
  p.update_min_a = 0.0;
  return p;
}

struct FilterRun {
  std::vector<FilterStep> steps;
  std::vector<std::size_t> scans;  // scan index of each step
};

// Feeds `scans` (indices into the world's sequence) with an odometry track that is continuous even where the
// scan indices jump (a kidnapping): each step adds the odometry's own relative motion of that scan.
FilterRun run_filter(ParticleFilter& filter, const std::vector<std::size_t>& scans, bool with_odometry = true) {
  const World& w = world();
  FilterRun r;
  Pose odom = w.odometry[scans.front()];
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const std::size_t i = scans[k];
    if (k > 0 && i > 0) odom = odom * (w.odometry[i - 1].inverse() * w.odometry[i]);
    r.steps.push_back(filter.update(kScanPeriod * static_cast<double>(k), w.points[i],
                                    with_odometry ? std::optional<Pose>(odom) : std::nullopt));
    r.scans.push_back(i);
    if (std::getenv("TSDF_MCL_TEST_DEBUG")) {
      const FilterStep& s = r.steps.back();
      std::fprintf(stderr, "step %zu: err %.2f %s cov %.2f inl %.2f impl %d share %.2f wf %.2f ws %.2f inj %zu\n", k,
                   test::translation_error(s.estimate.pose, w.truth[i]), to_string(s.state), s.estimate.coverage,
                   s.estimate.inlier_ratio, s.implausible, s.random_share, s.w_fast, s.w_slow, s.injected);
    }
  }
  return r;
}

std::vector<std::size_t> range(std::size_t begin, std::size_t end) {
  std::vector<std::size_t> v;
  for (std::size_t i = begin; i < end; ++i) v.push_back(i);
  return v;
}

double error_t(const FilterRun& r, std::size_t k) {
  return test::translation_error(r.steps[k].estimate.pose, world().truth[r.scans[k]]);
}
double error_r(const FilterRun& r, std::size_t k) {
  return test::rotation_error(r.steps[k].estimate.pose, world().truth[r.scans[k]]);
}

// One global localization run shared by the tests that look at different aspects of it.
const FilterRun& global_run() {
  static const FilterRun run = [] {
    auto eval = cpu_evaluator(world().map);
    ParticleFilter filter(world().map, *eval, ground_robot(), 256);
    filter.initialize_global();
    return run_filter(filter, range(0, 30));
  }();
  return run;
}

TEST(GlobalLocalization, ConvergesToTheTruePose) {
  const FilterRun& r = global_run();
  EXPECT_FALSE(r.steps[0].estimate.converged) << "one scan of a uniform belief is not convergence";
  std::size_t first_converged = r.steps.size();
  for (std::size_t k = 0; k < r.steps.size(); ++k) {
    if (r.steps[k].estimate.converged) {
      first_converged = k;
      break;
    }
  }
  // The step it first converges at moves by one or two with the compiler's rounding (gcc 8, clang 9); from
  // step 10 on it must hold.
  EXPECT_GE(first_converged, 2u) << "converged needs three consecutive updates (converged_min_updates)";
  for (std::size_t k = 10; k < r.steps.size(); ++k) {
    EXPECT_TRUE(r.steps[k].estimate.converged) << "step " << k;
    EXPECT_LT(error_t(r, k), 0.15) << "step " << k;
    EXPECT_LT(error_r(r, k), 3 * kDeg) << "step " << k;
  }
  EXPECT_LT(error_t(r, r.steps.size() - 1), 0.08);
}

// Subset-first weighing (the first updates of 20,000 particles take it) is an approximation for the particles
// it leaves out: without it the filter must localize alike, and with it the same.
TEST(GlobalLocalization, WholeScanWeighingLocalizesAlike) {
  FilterParameters p = ground_robot();
  p.subset_first.points = 0;
  auto eval = cpu_evaluator(world().map);
  ParticleFilter filter(world().map, *eval, p, 256);
  filter.initialize_global();
  const FilterRun whole = run_filter(filter, range(0, 30));
  const FilterRun& subset = global_run();
  ASSERT_EQ(subset.steps[0].particles, 20000u);
  for (const FilterRun* r : {&whole, &subset}) {
    for (std::size_t k = 10; k < r->steps.size(); ++k) {
      EXPECT_TRUE(r->steps[k].estimate.converged) << "step " << k;
      EXPECT_LT(error_t(*r, k), 0.15) << "step " << k;
      EXPECT_LT(error_r(*r, k), 3 * kDeg) << "step " << k;
    }
  }
}

TEST(GlobalLocalization, KldShrinksTheParticleSetAfterConvergence) {
  const FilterRun& r = global_run();
  EXPECT_EQ(r.steps[0].particles, 20000u);
  EXPECT_GT(r.steps[0].kld_bins, 5000u);
  for (std::size_t k = 10; k < r.steps.size(); ++k) {
    EXPECT_LE(r.steps[k].next_particles, 2000u) << "step " << k;
    EXPECT_GE(r.steps[k].next_particles, 300u) << "step " << k;
  }
}

TEST(Tracking, FollowsTheTrajectoryFromAGivenPose) {
  const World& w = world();
  auto eval = cpu_evaluator(w.map);
  FilterParameters p = ground_robot();
  p.initial_particles = 2000;
  ParticleFilter filter(w.map, *eval, p, 256);
  // Start 0.36 m and 8° off.
  filter.initialize_local(w.truth[40] * pose_from_xyz_rpy(0.3, -0.2, 0.05, 0.0, 0.0, 8 * kDeg));
  const FilterRun r = run_filter(filter, range(40, 80));
  for (std::size_t k = 3; k < r.steps.size(); ++k) {
    EXPECT_LT(error_t(r, k), 0.15) << "step " << k;
    EXPECT_LT(error_r(r, k), 3 * kDeg) << "step " << k;
  }
  EXPECT_LT(error_t(r, r.steps.size() - 1), 0.08);
  EXPECT_EQ(r.steps.back().injected, 0u);
}

// No odometry: along the first straight 2.8 m the constant-velocity model keeps up with the robot, where the
// random walk alone falls behind by most of a step each scan. Measured on the particles themselves: the estimate
// is refined onto the map (scan_fit.hpp) and hides a lagging cloud.
TEST(Tracking, ConstantVelocityWithoutOdometry) {
  const World& w = world();
  auto eval = cpu_evaluator(w.map);
  auto final_error = [&](MotionModelType type) {
    FilterParameters p = ground_robot();
    p.initial_particles = 2000;
    p.motion.type = type;
    ParticleFilter filter(w.map, *eval, p, 256);
    filter.initialize_local(w.truth[0]);
    const FilterRun r = run_filter(filter, range(0, 8), false);
    if (type == MotionModelType::kConstantVelocity) {
      for (std::size_t k = 0; k < r.steps.size(); ++k) EXPECT_LT(error_t(r, k), 0.3) << "step " << k;
    }
    const ParticleArrays particles = filter.particles();
    const std::vector<double> weights = filter.particle_weights();
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < weights.size(); ++i) mean += weights[i] * particles.position(i).cast<double>();
    return (mean - w.truth[r.scans.back()].translation()).norm();
  };
  const double cv = final_error(MotionModelType::kConstantVelocity);
  const double diffusion = final_error(MotionModelType::kDiffusion);
  EXPECT_LT(cv, 0.5 * diffusion);
}

// Tracking converged, then the robot is carried elsewhere (the scans jump ahead by 45, the odometry does not
// notice). Recovery injects random particles and the filter finds itself again without a restart.
// Kidnapped after 30 scans: the background search (challengers) finds the new place; without it, recovery's
// random particles must.
TEST(Kidnapping, FilterRecoversWithoutARestart) {
  for (const bool challengers : {true, false}) {
    SCOPED_TRACE(challengers ? "with challengers" : "recovery alone");
    const World& w = world();
    auto eval = cpu_evaluator(w.map);
    FilterParameters p = ground_robot();
    p.initial_particles = 2000;
    if (!challengers) p.recovery.challenger_candidates = 0;
    ParticleFilter filter(w.map, *eval, p, 256);
    filter.initialize_local(w.truth[0]);
    std::vector<std::size_t> scans = range(0, 30);
    const std::size_t jump = scans.size();
    for (std::size_t i = 75; i < 120; ++i) scans.push_back(i);
    const FilterRun r = run_filter(filter, scans);

    EXPECT_LT(error_t(r, jump - 1), 0.1) << "tracking before the kidnapping";
    ASSERT_GT(test::translation_error(w.truth[r.scans[jump - 1]], w.truth[r.scans[jump]]), 1.0) << "a kidnapping";
    // The challengers may find the new place within the same update; recovery alone cannot.
    if (!challengers) {
      EXPECT_GT(error_t(r, jump), 1.0) << "the estimate must stay behind at first";
    }
    std::size_t injected = 0;
    std::size_t recovered = r.steps.size();
    for (std::size_t k = jump; k < r.steps.size(); ++k) {
      injected += r.steps[k].injected + r.steps[k].challengers;
      if (recovered == r.steps.size() && error_t(r, k) < 0.15 && r.steps[k].estimate.converged) recovered = k;
      if (r.steps[k].estimate.converged) {
        EXPECT_LT(error_t(r, k), 1.0) << "converged while wrong at step " << k;
      }
    }
    EXPECT_GT(injected, challengers ? 100u : 500u) << "the search must have acted";
    ASSERT_LE(recovered, jump + 30) << "not re-localized within 30 updates";
    // The track settles within a few updates of being found and stays.
    for (std::size_t k = recovered + 2; k < r.steps.size(); ++k) {
      EXPECT_LT(error_t(r, k), 0.2) << "step " << k;
      EXPECT_LT(error_r(r, k), 5 * kDeg) << "step " << k;
    }
    EXPECT_LT(error_t(r, r.steps.size() - 1), 0.05);
    EXPECT_LE(r.steps.back().next_particles, 2000u) << "back to a small set once found";
  }
}

// Scans 0.4 m apart with update_min_d = 0.5: every second scan is held; a held scan's estimate is the last
// estimate moved by the odometry since. Before the first convergence a second without an update also opens
// the gate (roughening_interval).
TEST(MotionGate, HoldsSmallMotionsAndPropagatesTheEstimate) {
  const World& w = world();
  auto eval = cpu_evaluator(w.map);
  FilterParameters p = ground_robot();
  p.initial_particles = 1000;
  p.update_min_d = 0.5;
  p.update_min_a = 1.0;
  ParticleFilter filter(w.map, *eval, p, 256);
  filter.initialize_local(w.truth[0]);
  Pose last_update_estimate = Pose::Identity();
  std::size_t last_update_scan = 0;
  std::size_t held = 0;
  bool converged = false;
  for (std::size_t i = 0; i < 20; ++i) {
    const FilterStep s = filter.update(kScanPeriod * static_cast<double>(i), w.points[i], w.odometry[i]);
    const bool moved_enough = (w.odometry[last_update_scan].inverse() * w.odometry[i]).translation().norm() >= 0.5;
    const bool settling =
        !converged && kScanPeriod * static_cast<double>(i - last_update_scan) >= p.roughening.interval;
    EXPECT_EQ(s.updated, i == 0 || moved_enough || settling) << "scan " << i;
    if (s.updated) {
      last_update_estimate = s.estimate.pose;
      last_update_scan = i;
      converged = converged || s.estimate.converged;
    } else {
      ++held;
      const Pose expected = last_update_estimate * (w.odometry[last_update_scan].inverse() * w.odometry[i]);
      EXPECT_TRUE(s.estimate.pose.isApprox(expected, 1e-9)) << "scan " << i;
    }
    EXPECT_LT(test::translation_error(s.estimate.pose, w.truth[i]), 0.2) << "scan " << i;
  }
  EXPECT_GE(held, 7u);
}

// Roughening serves a sparse belief. Started around a known pose, the belief is concentrated after its first update,
// and its particles then move exactly as a filter's without roughening (the same draws of the same noise); started
// spread over the room, they are roughened before they first converge.
TEST(Roughening, StopsWhileTheDominantPlaceHoldsTheBelief) {
  const World& w = world();
  struct Run {
    bool concentrated = false;
    bool converged = false;
    std::vector<float> xyz;  // the particles after the second update
  };
  const auto run = [&](const LocalInitSpread& spread, bool roughening) {
    auto eval = cpu_evaluator(w.map);
    FilterParameters p = ground_robot();
    p.initial_particles = 2000;
    p.kld.min_particles = 2000;
    p.kld.max_particles = 2000;
    if (!roughening) p.roughening.xyz = p.roughening.angle = 0.0;
    ParticleFilter filter(w.map, *eval, p, 256);
    filter.initialize_local(w.truth[0], spread);
    Run r;
    const FilterStep first = filter.update(0.0, w.points[0], w.odometry[0]);
    r.concentrated = first.concentrated;
    r.converged = filter.update(kScanPeriod, w.points[1], w.odometry[1]).estimate.converged;
    const ParticleArrays a = filter.particles();
    for (std::size_t i = 0; i < filter.particle_count(); ++i) r.xyz.insert(r.xyz.end(), {a.x[i], a.y[i], a.z[i]});
    return r;
  };
  LocalInitSpread tight;
  tight.sigma_xy = 0.05;
  tight.sigma_z = 0.02;
  tight.sigma_yaw = 0.02;
  tight.sigma_roll_pitch = 0.01;
  const Run on = run(tight, true);
  ASSERT_TRUE(on.concentrated);
  ASSERT_FALSE(on.converged);  // roughening would still be due
  EXPECT_EQ(on.xyz, run(tight, false).xyz);
  LocalInitSpread wide;
  wide.sigma_xy = 2.0;
  wide.sigma_yaw = M_PI;
  const Run spread_on = run(wide, true);
  ASSERT_FALSE(spread_on.concentrated);
  EXPECT_NE(spread_on.xyz, run(wide, false).xyz);
}

std::vector<Pose> global_estimates(std::uint64_t seed, int threads, std::vector<std::size_t>* counts) {
  const World& w = world();
  auto eval = cpu_evaluator(w.map, threads);
  FilterParameters p = ground_robot();
  p.initial_particles = 5000;
  p.kld.max_particles = 5000;
  p.seed = seed;
  ParticleFilter filter(w.map, *eval, p, 256);
  filter.initialize_global();
  std::vector<Pose> out;
  for (const FilterStep& s : run_filter(filter, range(0, 6)).steps) {
    out.push_back(s.estimate.pose);
    counts->push_back(s.next_particles);
  }
  return out;
}

TEST(Determinism, SameSeedSameResultForAnyThreadCount) {
  const int threads = omp_get_max_threads();
  std::vector<std::size_t> counts_a, counts_b, counts_c;
  omp_set_num_threads(2);
  const std::vector<Pose> a = global_estimates(7, 2, &counts_a);
  omp_set_num_threads(1);
  const std::vector<Pose> b = global_estimates(7, 1, &counts_b);
  omp_set_num_threads(threads);
  const std::vector<Pose> c = global_estimates(8, 2, &counts_c);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].matrix(), b[k].matrix()) << "step " << k;
  }
  EXPECT_EQ(counts_a, counts_b);
  EXPECT_FALSE(a[0].matrix() == c[0].matrix()) << "another seed must give another initial set";
}

TEST(ParticleFilterInput, ClearErrors) {
  const World& w = world();
  auto eval = cpu_evaluator(w.map);
  FilterParameters p = ground_robot();
  p.initial_particles = 100;
  ParticleFilter filter(w.map, *eval, p, 256);
  EXPECT_THROW(filter.update(0.0, w.points[0], w.odometry[0]), Error);  // not initialized
  filter.initialize_local(w.truth[0]);
  EXPECT_THROW(filter.update(0.0, {}, w.odometry[0]), Error);          // empty scan
  EXPECT_THROW(filter.update(0.0, w.points[0], std::nullopt), Error);  // odometry model without odometry
  FilterParameters bad = p;
  bad.kld.min_particles = 0;
  EXPECT_THROW(ParticleFilter(w.map, *eval, bad), Error);
  bad = p;
  bad.recovery.alpha_slow = 0.5;  // slow faster than fast
  EXPECT_THROW(ParticleFilter(w.map, *eval, bad), Error);
}

}  // namespace
}  // namespace tsdf_mcl
