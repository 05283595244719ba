// Global localization without priors on synthetic buildings: gravity and height from the scan, the screened
// global search, a building of two identical wings (ambiguous until one feature comes into view), a forced
// wrong lock that must be abandoned. CPU backend (deterministic and fast).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <vector>

#include "filter_test_runs.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/filter/scan_gravity.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kScanPeriod = 0.5;  // s

using test::Box;
using test::cpu_evaluator;
using test::scan_route;
using test::Scans;

Pose mirrored(const Pose& p) {
  Pose m = Pose::Identity();
  m.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix() * p.linear();
  m.translation() = Eigen::Vector3d(24.0 - p.translation().x(), 8.0 - p.translation().y(), p.translation().z());
  return m;
}

// From room A through its door and along the corridor past the niche: 0.3 m steps, yaw along the path.
std::vector<Pose> twin_wing_route() { return test::route_through({{1.5, 3.0}, {4.5, 4.0}, {6.1, 4.0}, {16.5, 4.0}}); }

// The twin-wing building with the cabinet, its map and the walk past the niche (drifting odometry, scans).
struct TwinWingWalk {
  TsdfMap map;
  std::vector<Pose> truth, odometry;
  Scans scans;
};
TwinWingWalk twin_wing_walk() {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  TwinWingWalk w{test::make_box_map(boxes, Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(24.2f, 8.2f, 2.8f)),
                 twin_wing_route(),
                 {},
                 {}};
  w.odometry = test::drifting_odometry(w.truth, 7);
  w.scans = scan_route(boxes, w.truth, 5);
  return w;
}

// TSDF_MCL_TEST_DEBUG=1 prints every step (for tuning, never in CI).
void debug_step(std::size_t i, const FilterStep& s, const Pose& truth) {
  if (!std::getenv("TSDF_MCL_TEST_DEBUG")) return;
  std::fprintf(
      stderr, "step %zu: err %.2f m %s (%s) conc %d impl %d rivals %zu inl %.2f n %zu->%zu inj %zu+%zu+%zu beta %.3g |",
      i, test::translation_error(s.estimate.pose, truth), to_string(s.state), to_string(s.reason), s.concentrated,
      s.implausible, s.rivals.size(), s.estimate.inlier_ratio, s.particles, s.next_particles, s.injected, s.challengers,
      s.restored, s.tempering);
  for (const Place& h : s.estimate.places) {
    std::fprintf(stderr, " %.3f@(%.1f,%.1f)i%.2f", h.weight, h.pose.translation().x(), h.pose.translation().y(),
                 h.inlier_ratio);
  }
  std::fprintf(stderr, "\n");
}

TEST(ScanGravity, FindsUpAndHeightOnTiltedAndSidewaysSensors) {
  const std::vector<Box> boxes = test::office_boxes();
  Rng rng(11);
  // (x, y, z, roll, pitch, yaw): level, tilted like a drone or a handheld sensor, mounted sideways, upside down.
  const std::vector<std::array<double, 6>> poses = {
      {2.0, 1.2, 0.5, 0.0, 0.0, 0.3},    {8.0, 3.6, 1.5, 0.2, -0.15, 2.0}, {12.0, 3.5, 1.1, -0.35, 0.1, -1.0},
      {3.0, 5.0, 0.9, 1.5708, 0.0, 0.7}, {9.6, 7.5, 1.3, 0.0, -1.2, 1.2},  {5.2, 3.0, 1.8, 3.1416, 0.0, 0.0},
  };
  for (const auto& v : poses) {
    const Pose pose = pose_from_xyz_rpy(v[0], v[1], v[2], v[3], v[4], v[5]);
    // An OS0-like field of view (+-45 deg): it sees the floor close by whatever the tilt.
    const GravityEstimate g = estimate_gravity(test::simulate_scan(boxes, pose, rng, 32, 360, 0.01f, 45.0f));
    const Eigen::Vector3f up = (pose.linear().transpose() * Eigen::Vector3d::UnitZ()).cast<float>();
    const GravityCandidate* match = nullptr;
    for (const GravityCandidate& c : g.candidates) {
      if (std::acos(std::clamp(c.up.dot(up), -1.0f, 1.0f)) < 2.0 * kDeg) match = &c;
    }
    ASSERT_NE(match, nullptr) << "no candidate within 2 deg of up at roll " << v[3] << " pitch " << v[4];
    EXPECT_LE(g.candidates.size(), 6u);
    ASSERT_TRUE(match->has_height) << "no floor below at roll " << v[3] << " pitch " << v[4];
    EXPECT_NEAR(match->height, v[2], 0.1) << "sensor height at roll " << v[3] << " pitch " << v[4];
  }
  // No planes: no candidate (the caller falls back to rotations uniform over SO(3)).
  std::vector<Eigen::Vector3f> cloud;
  for (int i = 0; i < 5000; ++i) {
    cloud.emplace_back(static_cast<float>(rng.uniform(-8, 8)), static_cast<float>(rng.uniform(-8, 8)),
                       static_cast<float>(rng.uniform(-8, 8)));
  }
  EXPECT_TRUE(estimate_gravity(cloud).candidates.empty());
  // A known up (IMU) gives that one candidate, with the height the scan shows along it.
  const Pose level = pose_from_xyz_rpy(2.0, 1.2, 0.7, 0.0, 0.0, 0.3);
  const GravityEstimate imu = estimate_gravity(test::simulate_scan(boxes, level, rng), {}, Eigen::Vector3f::UnitZ());
  ASSERT_EQ(imu.candidates.size(), 1u);
  EXPECT_TRUE(imu.candidates[0].up.isApprox(Eigen::Vector3f::UnitZ()));
  EXPECT_NEAR(imu.candidates[0].height, 0.7, 0.1);
}

// No tilt, no height band, no initial guess: the first scan's structure guides the search.
TEST(GlobalSearch, LocalizesWithoutPriorsAndClaimsConvergenceOnlyWhenRight) {
  const std::vector<Box> boxes = test::office_boxes();
  const TsdfMap map = test::make_office_map();
  const std::vector<Pose> truth = test::office_trajectory(40);
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 5);
  const Scans scans = scan_route(boxes, truth, 3);
  auto eval = cpu_evaluator(map);
  ParticleFilter filter(map, *eval, test::small_building_parameters(), 256);
  ScanExtras extras;
  extras.dense = &scans.dense[0];
  filter.initialize_global(scans.points[0], extras);
  EXPECT_GE(filter.gravity_candidates().size(), 2u);
  std::size_t first_converged = truth.size();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    extras.dense = &scans.dense[i];
    const FilterStep step = filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras);
    debug_step(i, step, truth[i]);
    const double error = test::translation_error(step.estimate.pose, truth[i]);
    if (step.estimate.converged) {
      first_converged = std::min(first_converged, i);
      EXPECT_LT(error, 0.3) << "converged while wrong at step " << i;
      EXPECT_LT(test::rotation_error(step.estimate.pose, truth[i]), 5 * kDeg) << "step " << i;
    }
  }
  EXPECT_LE(first_converged, 10u);
  EXPECT_TRUE(filter.estimate().converged);
}

// The two wings look the same until the niche with the cabinet comes into view: before that the belief must
// hold both (a hypothesis at the true pose and one at its mirror image) and never claim convergence; after it,
// converge at the true pose.
TEST(GlobalSearch, TwinWingsStayAmbiguousUntilTheFeatureThenConvergeRight) {
  const TwinWingWalk walk = twin_wing_walk();
  const auto& [map, truth, odometry, scans] = walk;
  auto eval = cpu_evaluator(map);
  ParticleFilter filter(map, *eval, test::small_building_parameters(), 256);
  ScanExtras extras;
  extras.dense = &scans.dense[0];
  filter.initialize_global(scans.points[0], extras);
  bool both_held = false;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    extras.dense = &scans.dense[i];
    const FilterStep step = filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras);
    debug_step(i, step, truth[i]);
    const double x = truth[i].translation().x();
    const auto weight_near = [&](const Pose& p) {
      double w = 0.0;
      for (const Place& h : step.estimate.places) {
        if (test::translation_error(h.pose, p) < 0.5 && test::rotation_error(h.pose, p) < 10 * kDeg) w += h.weight;
      }
      return w;
    };
    if (x < 9.0) {
      EXPECT_FALSE(step.estimate.converged)
          << "converged at step " << i << " (x " << x << ") before the cabinet was in view";
      if (i >= 8 && weight_near(truth[i]) > 0.01 && weight_near(mirrored(truth[i])) > 0.01) both_held = true;
    }
    if (x > 13.0) {
      EXPECT_TRUE(step.estimate.converged) << "step " << i << " (x " << x << ")";
      EXPECT_LT(test::translation_error(step.estimate.pose, truth[i]), 0.2) << "step " << i;
    }
    if (step.estimate.converged) {
      EXPECT_LT(test::translation_error(step.estimate.pose, truth[i]), 1.0) << "false convergence at step " << i;
    }
  }
  EXPECT_TRUE(both_held) << "the belief never held both wings while they looked alike";
}

// A belief that dropped the true wing gets it back level before the cabinet tells the wings apart: until the track
// first converges it was never proven against its look-alikes, and the look-alike memory gives the wing it has kept
// over 2 m of travel the share its evidence does (filter_decision.cpp, plan_restore), about half. The
// cabinet's first views then turn the estimate with no proof to wait for, and no wrong wing is claimed once the belief
// has held the true one. A small first search (4,000 candidates, 2,000 kept) holds one wing only in some seeds; so
// small a search may also miss the true wing altogether and converge on the mirror before the challengers find it,
// the limit "the honesty of converged rests on the search having found the right place somewhere" (docs/filter.md):
// such a seed is no case of this test. Every other seed that lacked the true wing must come back.
TEST(GlobalSearch, ADroppedWingComesBackLevelBeforeTheCabinet) {
  const TwinWingWalk walk = twin_wing_walk();
  const auto& [map, truth, odometry, scans] = walk;
  const double cabinet_x = 9.7;  // the cabinet comes into view
  std::size_t cases = 0;         // seeds that lacked the true wing without having claimed the mirror
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    auto eval = cpu_evaluator(map);
    FilterParameters p = test::small_building_parameters();
    p.seed = seed;
    p.initial_particles = 2000;
    p.global_search.candidates = 4000;
    // The belief must drop a wing for the memory to bring it back: tied places started equal keep both.
    p.places.even_tied = false;
    ParticleFilter filter(map, *eval, p, 256);
    ScanExtras extras;
    extras.dense = &scans.dense[0];
    filter.initialize_global(scans.points[0], extras);
    bool held = false;           // the belief has held the true wing (a tenth of it)
    bool claimed_blind = false;  // converged before it ever had
    bool lacked = false;  // the belief has held less than a hundredth at the true wing, nine tenths at the mirror
    bool level = false;   // and then a fifth to four fifths of it at the true wing, before the cabinet
    std::size_t right_from = 0;
    std::size_t cabinet_step = truth.size();
    for (std::size_t i = 0; i < truth.size(); ++i) {
      extras.dense = &scans.dense[i];
      const FilterStep step = filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras);
      debug_step(i, step, truth[i]);
      const auto weight_near = [&](const Pose& at) {
        double w = 0.0;
        for (const Place& h : step.estimate.places) {
          if (test::translation_error(h.pose, at) < 0.5 && test::rotation_error(h.pose, at) < 10 * kDeg) w += h.weight;
        }
        return w;
      };
      const double true_wing = weight_near(truth[i]);
      const bool before_cabinet = truth[i].translation().x() < cabinet_x;
      if (!before_cabinet) cabinet_step = std::min(cabinet_step, i);
      if (true_wing < 0.01 && weight_near(mirrored(truth[i])) > 0.9) lacked = true;
      if (lacked && before_cabinet && true_wing > 0.2 && true_wing < 0.8) level = true;
      held = held || true_wing > 0.1;
      claimed_blind = claimed_blind || (!held && step.estimate.converged);
      const double error = test::translation_error(step.estimate.pose, truth[i]);
      if (error > 0.3) right_from = i + 1;
      if (held && step.estimate.converged) {
        EXPECT_LT(error, 0.3) << "seed " << seed << ": converged on the wrong wing at step " << i
                              << ", after the belief had held the true one";
      }
    }
    EXPECT_LT(test::translation_error(filter.estimate().pose, truth.back()), 0.2) << "seed " << seed;
    if (std::getenv("TSDF_MCL_TEST_DEBUG")) {
      std::fprintf(stderr, "seed %llu: lacked %d claimed blind %d level %d right from step %zu, cabinet from %zu\n",
                   static_cast<unsigned long long>(seed), lacked, claimed_blind, level, right_from, cabinet_step);
    }
    if (!lacked || claimed_blind) continue;
    ++cases;
    EXPECT_TRUE(level) << "seed " << seed << ": the true wing never came back level before the cabinet";
    EXPECT_LE(right_from, cabinet_step + 1)
        << "seed " << seed << ": the cabinet's first sight did not turn the estimate";
  }
  // Measured: seeds 2 and 6 lacked the true wing, held it level again long before the cabinet and were right from step
  // 27, two steps before the cabinet's first sight; with a proof only (no shares before the first convergence) both
  // turned on the proof at step 29, never level before. Seed 1 converged on the mirror wing at step 8, before the
  // challengers first found the true one, and the proof at the cabinet turned it at step 35. The other five held both
  // wings throughout. (Seeds 9-16: one more claimed blind, none lacked otherwise.)
  EXPECT_GE(cases, 1u) << "no seed lacked the true wing: the test's premise is gone";
}

// hypothesis_min_weight above converged_competitor_weight: a hypothesis credible enough to compete but too light to
// keep joins the rest, and resampling must not give its emptied group particles to draw (it threw "group 2 has no
// particles to draw from" on the first update).
TEST(GlobalSearch, PlacesTooLightToKeepJoinTheRest) {
  const TwinWingWalk walk = twin_wing_walk();
  const auto& [map, truth, odometry, scans] = walk;
  auto eval = cpu_evaluator(map);
  FilterParameters p = test::small_building_parameters();
  p.places.min_weight = 0.3;
  ParticleFilter filter(map, *eval, p, 256);
  ScanExtras extras;
  extras.dense = &scans.dense[0];
  filter.initialize_global(scans.points[0], extras);
  for (std::size_t i = 0; i < 6; ++i) {
    extras.dense = &scans.dense[i];
    FilterStep step;
    ASSERT_NO_THROW(step = filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras))
        << "step " << i;
    EXPECT_EQ(step.next_particles, filter.particle_count());
  }
}

// Forced onto a wrong place (5 m off in the asymmetric office), the filter must notice the poor fit, search
// again and find the true pose, without claiming convergence at the wrong place.
TEST(GlobalSearch, AbandonsAForcedWrongLock) {
  const std::vector<Box> boxes = test::office_boxes();
  const TsdfMap map = test::make_office_map();
  const std::vector<Pose> truth = test::office_trajectory(50);
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 9);
  const Scans scans = scan_route(boxes, truth, 4);
  auto eval = cpu_evaluator(map);
  FilterParameters p = test::small_building_parameters();
  ParticleFilter filter(map, *eval, p, 256);
  Pose wrong = truth[0];
  wrong.translation() += Eigen::Vector3d(4.0, 3.0, 0.0);
  filter.initialize_local(wrong);
  std::size_t recovered = truth.size();
  std::size_t searched = 0;
  ScanExtras extras;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    extras.dense = &scans.dense[i];
    const FilterStep step = filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras);
    debug_step(i, step, truth[i]);
    searched += step.injected + step.challengers;
    const double error = test::translation_error(step.estimate.pose, truth[i]);
    if (step.estimate.converged) {
      EXPECT_LT(error, 0.3) << "converged while wrong at step " << i;
      recovered = std::min(recovered, i);
    }
  }
  EXPECT_GT(searched, 0u) << "the wrong lock was never questioned";
  EXPECT_LE(recovered, 25u);
  EXPECT_TRUE(filter.estimate().converged);
  EXPECT_LT(test::translation_error(filter.estimate().pose, truth.back()), 0.2);
}

}  // namespace
}  // namespace tsdf_mcl
