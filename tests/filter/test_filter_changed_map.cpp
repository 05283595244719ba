// Keeping a right track where the map runs out or has changed (issue: unknown is unknown, a jump needs proof):
// a room the mapping run skipped whose mapped twin lies 12 m away, furniture moved and a door opened after
// mapping, and a two-floor building whose floors repeat one plan. CPU backend (deterministic and fast).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "filter_test_runs.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kScanPeriod = 0.5;  // s

using test::Box;
using test::box;
using test::cpu_evaluator;
using test::route_through;
using test::scan_route;
using test::Scans;

// TSDF_MCL_TEST_DEBUG=1 prints every step (for tuning, never in CI).
void debug_step(std::size_t i, const FilterStep& s, const Pose& truth) {
  if (!std::getenv("TSDF_MCL_TEST_DEBUG")) return;
  std::fprintf(stderr, "step %zu: err %.2f m dz %.2f %s cov %.2f inl %.2f hold %d ev %.1f n %zu |", i,
               test::translation_error(s.estimate.pose, truth),
               s.estimate.pose.translation().z() - truth.translation().z(), to_string(s.state), s.estimate.coverage,
               s.estimate.inlier_ratio, s.holding, s.challenge_evidence, s.particles);
  for (const Place& h : s.estimate.places) {
    std::fprintf(stderr, " %.3f@(%.1f,%.1f,%.1f)i%.2fc%.2f", h.weight, h.pose.translation().x(),
                 h.pose.translation().y(), h.pose.translation().z(), h.inlier_ratio, h.coverage);
  }
  std::fprintf(stderr, "\n");
}

struct FilterRun {
  std::vector<FilterStep> steps;
};
FilterRun run(ParticleFilter& filter, const Scans& scans, const std::vector<Pose>& truth,
              const std::vector<Pose>& odometry) {
  FilterRun r;
  ScanExtras extras;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    extras.dense = &scans.dense[i];
    r.steps.push_back(filter.update(kScanPeriod * static_cast<double>(i), scans.points[i], odometry[i], extras));
    debug_step(i, r.steps.back(), truth[i]);
  }
  return r;
}

// The twin-wing building's route from the west room along the corridor into the east room.
std::vector<Pose> into_the_east_room() {
  return route_through({{1.5, 3.0}, {4.5, 4.0}, {17.0, 4.0}, {20.5, 4.0}, {21.5, 2.0}});
}

// Tracks `truth` from its first pose in `map`, scans simulated in `boxes`, drifting odometry.
FilterRun track_route(const TsdfMap& map, const std::vector<Box>& boxes, const std::vector<Pose>& truth) {
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 11);
  const Scans scans = scan_route(boxes, truth, 6);
  auto eval = cpu_evaluator(map);
  ParticleFilter filter(map, *eval, test::small_building_parameters(), 256);
  filter.initialize_local(truth[0]);
  return run(filter, scans, truth, odometry);
}

// A global search from `truth`'s first scan in `map` that then follows the route (scans simulated in `boxes` with
// scan_seed, odometry drifting with odometry_seed).
FilterRun search_route(const TsdfMap& map, const std::vector<Box>& boxes, const std::vector<Pose>& truth,
                       std::uint64_t odometry_seed, std::uint64_t scan_seed) {
  const std::vector<Pose> odometry = test::drifting_odometry(truth, odometry_seed);
  const Scans scans = scan_route(boxes, truth, scan_seed);
  auto eval = cpu_evaluator(map);
  ParticleFilter filter(map, *eval, test::small_building_parameters(), 256);
  ScanExtras extras;
  extras.dense = &scans.dense[0];
  filter.initialize_global(scans.points[0], extras);
  return run(filter, scans, truth, odometry);
}

// The building of two identical wings (filter_test_scene.hpp), mapped without the east room: the mapping run
// saw the corridor up to the room's wall and never entered. The robot tracks from the west room along the
// corridor into the east room, whose mapped twin (the west room, turned by half a turn) explains its scans
// perfectly while at the true pose most points land in space the map never observed.
TEST(ChangedMap, TheTrackHoldsIntoAnUnmappedRoomAndSaysSo) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map =
      test::make_box_map(boxes, Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(18.0f, 8.2f, 2.8f));
  const std::vector<Pose> truth = into_the_east_room();
  const FilterRun r = track_route(map, boxes, truth);
  bool converged_before = false;
  std::size_t unmapped = 0, deep = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const FilterStep& s = r.steps[i];
    const double error = test::translation_error(s.estimate.pose, truth[i]);
    EXPECT_LT(error, 0.5) << "the track jumped at step " << i;
    EXPECT_LT(test::rotation_error(s.estimate.pose, truth[i]), 10 * kDeg) << "step " << i;
    if (s.estimate.converged) {
      EXPECT_LT(error, 0.3) << "converged while off at step " << i;
    }
    const double x = truth[i].translation().x();
    if (x < 16.0 && s.estimate.converged) converged_before = true;
    if (x > 19.5) {
      ++deep;
      unmapped += s.state == TrackState::kUnmapped;
      EXPECT_LT(s.estimate.coverage, 0.5) << "step " << i;
      EXPECT_NE(s.state, TrackState::kLost) << "step " << i;
      EXPECT_FALSE(s.estimate.converged) << "step " << i;
    }
  }
  EXPECT_TRUE(converged_before);
  ASSERT_GT(deep, 5u);
  EXPECT_GE(unmapped, deep - 1) << "the state must say: tracking through unmapped space";
  EXPECT_EQ(r.steps.back().state, TrackState::kUnmapped);
}

// The same building and route, but the map integrated from the scans of a mapping run that stopped in the corridor
// 2 m before the east room: what the map holds of that room is its frontier, surfaces seen once through the door
// at grazing angles, which fits the scans taken inside worse than the mapped west room does wherever the robot
// stands. That made the track jump to the west room within a few scans (the "frontier evidence waits" rule of
// ParticleFilter::weigh_hypotheses); the track must hold and say it is in unmapped space.
// The map integrated from the scans of a mapping run through `boxes` that stops in the corridor at x = `stop` (m; the
// east room's wall stands at 17.8 m).
TsdfMap map_from_a_run_short_of_the_east_room(const std::vector<Box>& boxes, double stop) {
  test::TempDir dir;
  {
    Rng rng(3);
    DatasetWriter writer(dir.path());
    const std::vector<Pose> mapping = route_through({{1.5, 3.0}, {4.5, 4.0}, {stop, 4.0}});
    for (std::size_t i = 0; i < mapping.size(); ++i) {
      PointCloud cloud;
      cloud.points = test::simulate_scan(boxes, mapping[i], rng, 32, 360, 0.01f, 30.0f);
      writer.add(kScanPeriod * static_cast<double>(i), cloud, mapping[i], std::nullopt);
    }
    writer.close();
  }
  const Dataset dataset = Dataset::open(dir.path());
  std::vector<std::size_t> all(dataset.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  ScanMapOptions options;
  options.voxel_size = 0.1f;
  options.truncation = 0.3f;
  return build_map_from_scans(dataset, all, options);
}

TEST(ChangedMap, TheTrackHoldsPastTheFrontierOfAMapBuiltFromScans) {
  const std::vector<Box> boxes = test::twin_wing_boxes(true);
  const TsdfMap map = map_from_a_run_short_of_the_east_room(boxes, 15.8);
  const std::vector<Pose> truth = into_the_east_room();
  const FilterRun r = track_route(map, boxes, truth);
  std::size_t deep = 0, unmapped = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const FilterStep& s = r.steps[i];
    const double error = test::translation_error(s.estimate.pose, truth[i]);
    EXPECT_LT(error, 0.5) << "the track jumped at step " << i;
    if (s.estimate.converged) {
      EXPECT_LT(error, 0.3) << "converged while off at step " << i;
    }
    if (truth[i].translation().x() > 19.5) {
      ++deep;
      unmapped += s.state == TrackState::kUnmapped;
      EXPECT_NE(s.state, TrackState::kLost) << "step " << i;
    }
  }
  ASSERT_GT(deep, 5u);
  EXPECT_GE(unmapped, deep / 2) << "the state must say: tracking through unmapped space";
}

// The twin-wing building without its one difference, mapped by a run that stopped 5 m short of the east room (the
// corridor's east end and the room are its frontier, their twins mapped), and a global search from the corridor: the
// robot walking east towards the east room and its image walking west towards the west room see the same building
// until the robot stands in the east room's door. As that door comes into view the map covers less and less of the
// scan at the true place (0.63 at the end); the frontier must not hand the twin the belief before the room is even
// entered. In the matrix's symmetric-skip runs it did (0.05 of the belief while the coverage fell from 0.94 to 0.78,
// enough to move an estimate 18 m from a level start); in this box world it does not, with or without the waiting
// pairs (place_weighting.hpp: waiting_pairs, tested in PlaceWeighting.APairWaitsWhere...): the scene guards
// the behaviour, the matrix measures the rule.
TEST(ChangedMap, LookAlikePlacesStayLevelAsAnUnmappedRoomComesIntoView) {
  const std::vector<Box> boxes = test::twin_wing_boxes(false);
  const TsdfMap map = map_from_a_run_short_of_the_east_room(boxes, 13.0);
  const std::vector<Pose> truth = route_through({{8.0, 4.0}, {17.6, 4.0}});
  const FilterRun r = search_route(map, boxes, truth, 5, 7);
  // The share of the belief at the true place and at its image, (x, y, yaw) -> (24 - x, 8 - y, yaw + pi).
  const auto share_near = [&](std::size_t i, const Eigen::Vector3d& where) {
    double share = 0.0;
    for (const Place& h : r.steps[i].estimate.places) {
      if ((h.pose.translation() - where).head<2>().norm() < 1.0) share += h.weight;
    }
    return share;
  };
  double at_ten = -1.0;  // the true place's share with the robot at x = 10 m, 8 m short of the door
  double lowest_after = 1.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Eigen::Vector3d t = truth[i].translation();
    const Eigen::Vector3d image(24.0 - t.x(), 8.0 - t.y(), t.z());
    const double here = share_near(i, t), there = share_near(i, image);
    EXPECT_FALSE(r.steps[i].estimate.converged) << "step " << i << ": the wings look the same here";
    if (at_ten < 0.0 && t.x() >= 10.0) {
      ASSERT_GT(here, 0.2) << "the true place is not among the places at x = 10 m";
      ASSERT_GT(there, 0.2) << "its image is not among the places at x = 10 m";
      at_ten = here;
    } else if (at_ten >= 0.0) {
      lowest_after = std::min(lowest_after, here);
    }
  }
  ASSERT_GE(at_ten, 0.0);
  EXPECT_GT(lowest_after, at_ten - 0.02) << "the true place lost the belief to the door's frontier";
}

// A drone rising in the office whose map a ground robot made: the walls are mapped up to 1.6 m, above that (and the
// ceiling) the map never looked. Once the drone flies higher, a sunk pose puts more of the scan on the mapped band
// of the walls, which at the true pose lands in unobserved space: the particles below the truth fitted better, and
// the track sank (0.25-0.42 m in the office VLP-16 drone run of the matrix). Weighed against each other on the points
// clear of the frontier, they do not.
std::vector<Pose> rising_through_the_office() {
  std::vector<Pose> poses = route_through({{1.5, 6.0}, {1.5, 3.5}, {4.8, 3.6}, {8.0, 3.6}, {12.0, 3.5}});
  for (std::size_t i = 0; i < poses.size(); ++i) {
    // Takes off once localized: 0.9 m up to 1.9 m over poses 12 to 32.
    const double rise = std::clamp((static_cast<double>(i) - 12.0) / 20.0, 0.0, 1.0);
    poses[i].translation().z() += rise;
  }
  return poses;
}

// The office up to `mapped_height` (a ground robot's view) and, with `twin`, its twin 16 m east whole (mapped from
// higher up), built like test::make_box_map.
constexpr float kTwinShift = 16.0f;
TsdfMap office_map_up_to(float mapped_height, const std::vector<Box>& boxes, bool twin) {
  const auto observed = [&](const Eigen::Vector3f& c) {
    const bool in_twin = c.x() > 15.0f;  // the office ends at x = 14.2 m, the twin starts at 15.8 m
    return in_twin || c.z() <= mapped_height;
  };
  return test::make_box_map_where(boxes, Eigen::Vector3f(-0.2f, -0.2f, -0.2f),
                                  Eigen::Vector3f(twin ? 14.2f + kTwinShift : 14.2f, 9.2f, 2.8f), observed);
}

// The flight from the take-off on (`poses`): how many poses have the estimate's height more than 0.15 m off (`sunk`)
// or the estimate more than 1 m off (`off`), and on how many places more than 2 m away hold a fifth of the belief or
// more (`shared`); the frontier's points weighed (as before) or not (the default). With `twin`, the map holds a twin
// office 16 m east whole and the office only up to 1.3 m: above that the twin explains more of each scan.
struct Flight {
  std::size_t poses = 0, sunk = 0, off = 0, shared = 0;
  std::size_t ground_low = 0;  // poses before the take-off with the height more than 0.1 m off
};
Flight fly_above_the_mapped_band(bool frontier_evidence, bool twin = false,
                                 double wall_tilt_information = FilterParameters{}.places.wall_tilt_information) {
  std::vector<Box> boxes = test::office_boxes();
  if (twin) {
    const Eigen::Vector3f shift(kTwinShift, 0.0f, 0.0f);
    for (const Box& b : test::office_boxes()) boxes.push_back(Box{b.lo + shift, b.hi + shift});
  }
  const TsdfMap map = office_map_up_to(twin ? 1.3f : 1.6f, boxes, twin);
  const std::vector<Pose> truth = rising_through_the_office();
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 23);
  const Scans scans = scan_route(boxes, truth, 4);
  auto eval = cpu_evaluator(map);
  FilterParameters p = test::small_building_parameters();
  p.places.frontier_evidence = frontier_evidence;
  p.places.wall_tilt_information = wall_tilt_information;
  ParticleFilter filter(map, *eval, p, 256);
  filter.initialize_local(truth[0]);
  const FilterRun r = run(filter, scans, truth, odometry);
  Flight f;
  for (std::size_t i = 0; i < 12; ++i) {
    f.ground_low += std::abs(r.steps[i].estimate.pose.translation().z() - truth[i].translation().z()) > 0.1 ? 1 : 0;
  }
  for (std::size_t i = 12; i < truth.size(); ++i, ++f.poses) {
    const double dz = r.steps[i].estimate.pose.translation().z() - truth[i].translation().z();
    f.sunk += std::abs(dz) > 0.15 ? 1 : 0;
    f.off += test::translation_error(r.steps[i].estimate.pose, truth[i]) > 1.0 ? 1 : 0;
    double elsewhere = 0.0;
    for (const Place& h : r.steps[i].estimate.places) {
      if ((h.pose.translation() - truth[i].translation()).norm() > 2.0) elsewhere += h.weight;
    }
    f.shared += elsewhere >= 0.2 ? 1 : 0;
  }
  return f;
}

TEST(ChangedMap, ATrackAboveTheMappedBandKeepsItsHeight) {
  const Flight before = fly_above_the_mapped_band(true);
  const Flight now = fly_above_the_mapped_band(false);
  std::fprintf(stderr,
               "poses over 0.15 m too low or high, of %zu: frontier points weighed %zu, dropped %zu; on the ground "
               "before the take-off, over 0.1 m: %zu of 12\n",
               now.poses, before.sunk, now.sunk, now.ground_low);
  // Measured (walls at 3, the default): 0 against 32 (the sanitizer build: 0 against 34); on the ground 0 of 12.
  // Before the local start was a track to keep from its first update (evidence_centres), 11 of the 12 were over 0.1 m
  // low (the sanitizer build stayed 0.2 m low six poses into the climb too).
  EXPECT_EQ(now.off, 0u);
  EXPECT_LE(now.sunk, 2u);
  EXPECT_LE(now.ground_low, 1u) << "the start on the ground sank";
  EXPECT_GE(before.sunk, before.poses / 2) << "the scene no longer shows the sinking";
}

// The flight with the scan's walls off and at 6, twice the default (FilterParameters::wall_tilt_information): the
// height must not hang on that weight. Before the places' starts were compared on the points both observe and the
// track took in the particles 2 m around it (kTrackRadius), the drone sank on 15 of 34 poses at 6, on 0 with the walls
// off: particles 1.2 m below the track, weighed on the whole scan, whose unobserved points count as misses, pulled the
// belief down once they joined the track's mode. With the local start weighed on its points from the first update,
// 14 sank at 6 by another path, until the rest's evidence waited at the frontier too (weigh_hypotheses): stray
// particles took 57 % of the belief in one update, and the track, no longer concentrated, went onto the whole scan.
// Measured now: 0 at 0, 2, 3, 4, 6 and 8 (the sanitizer build: 2, 0, 0, 0, 0, 0).
TEST(ChangedMap, TheHeightHoldsWhateverTheWallsWeigh) {
  for (const double weight : {0.0, 6.0}) {
    const Flight f = fly_above_the_mapped_band(false, false, weight);
    std::fprintf(stderr, "walls weighing %.0f: %zu of %zu poses over 0.15 m too low or high\n", weight, f.sunk,
                 f.poses);
    EXPECT_EQ(f.off, 0u) << "walls " << weight;
    EXPECT_LE(f.sunk, 2u) << "walls " << weight;
  }
}

// The same flight beside a look-alike that the map holds whole: above the office's mapped band the twin explains more
// of each scan and draws belief (a fifth or more on most poses), so no place dominates. Each place is weighed on its
// own points (in the avz building with a skipped room, weighing only a dominant, concentrated place's let a drone's
// track sink 0.25 m while a look-alike 11 m away held up to half of the belief). The track holds its height and the
// estimate stays with it; with the frontier's points weighed, the estimate sank or moved to the twin.
TEST(ChangedMap, ATrackSharedWithALookAlikeKeepsItsHeight) {
  const Flight before = fly_above_the_mapped_band(true, true);
  const Flight now = fly_above_the_mapped_band(false, true);
  std::fprintf(stderr,
               "twin offices, of %zu poses: frontier points weighed: %zu over 1 m off, %zu over 0.15 m in height, the "
               "twin holding a fifth or more on %zu; dropped: %zu, %zu, %zu\n",
               now.poses, before.off, before.sunk, before.shared, now.off, now.sunk, now.shared);
  // Measured: 0, 0, 25 against 19, 15, 29 with the walls off (the sanitizer build, whose floats round otherwise: 0, 2,
  // 25 against 0, 13, 29); 0, 0, 25 against 0, 32, 25 with them at 3, the default (the sanitizer build: 0, 0, 15
  // against 0, 32, 29). The scene guards the rule, it does not reproduce the avz drone's sinking.
  EXPECT_EQ(now.off, 0u);
  EXPECT_LE(now.sunk, 3u);
  EXPECT_GE(now.shared, now.poses / 3) << "the twin no longer draws belief";
  EXPECT_GE(before.off + before.sunk, before.poses / 4) << "the scene no longer shows the hazard";
}

// A handheld sensor 1.5 m up walks the office whose map a ground robot made (walls mapped up to 1.6 m), its track
// started 0.35 m too low (a global search's first updates leave it so: lower, more of the scan lands on the walls'
// mapped band). On the points clear of the frontier the low pose holds itself: they are picked at the track's pose,
// and those the truth puts above the band land on it. The rays tell: lowered, the downward ones pass through the
// floor before they end. Counts the poses from the fifth on with the height more than 0.15 m off.
std::size_t poses_off_in_height(double see_through_weight, std::size_t* poses) {
  const std::vector<Box> boxes = test::office_boxes();
  const TsdfMap map = office_map_up_to(1.6f, boxes, false);
  std::vector<Pose> truth = route_through({{1.5, 6.0}, {1.5, 3.5}, {4.8, 3.6}, {8.0, 3.6}, {12.0, 3.5}});
  for (Pose& t : truth) t.translation().z() += 0.6;  // 1.5 m up
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 29);
  const Scans scans = scan_route(boxes, truth, 4);
  auto eval = cpu_evaluator(map);
  FilterParameters p = test::small_building_parameters();
  p.places.see_through_weight = see_through_weight;
  ParticleFilter filter(map, *eval, p, 256);
  Pose start = truth[0];
  start.translation().z() -= 0.35;
  LocalInitSpread tight;
  tight.sigma_z = 0.05;
  filter.initialize_local(start, tight);
  const FilterRun r = run(filter, scans, truth, odometry);
  std::size_t off = 0;
  *poses = 0;
  for (std::size_t i = 4; i < truth.size(); ++i, ++*poses) {
    EXPECT_LT(test::translation_error(r.steps[i].estimate.pose, truth[i]), 1.0) << "step " << i;
    off += std::abs(r.steps[i].estimate.pose.translation().z() - truth[i].translation().z()) > 0.15 ? 1 : 0;
  }
  return off;
}

TEST(ChangedMap, AHeightOffBelowTheMappedBandComesRightOnTheRays) {
  std::size_t poses = 0;
  const std::size_t points_only = poses_off_in_height(0.0, &poses);
  const std::size_t rays = poses_off_in_height(FilterParameters{}.places.see_through_weight, &poses);
  std::fprintf(stderr, "of %zu poses, over 0.15 m off in height: %zu on the points alone, %zu with the rays\n", poses,
               points_only, rays);
  // Measured: 8 of 42 on the points alone (low until the floor comes into view), 4 with the rays (3 updates to come
  // right, then low again at the first corner, where the turning cloud is too wide to be a place and takes the whole
  // scan).
  EXPECT_LE(rays, poses / 4);
  EXPECT_GT(points_only, rays) << "the scene no longer shows the low height held, or the rays no longer help";
}

// The office after mapping: the cabinet and the table moved, the sideboard gone, a new doorway in the wall
// between the west and the south-east room, a box left in the corridor. The track holds and stays honest.
TEST(ChangedMap, FurnitureMovedAndADoorOpenedAfterMapping) {
  std::vector<Box> changed;
  for (const Box& b : test::office_boxes()) {
    const bool wall_with_new_door = b.lo.x() == 6.0f && b.lo.y() == 4.2f;
    const bool sideboard = b.lo.x() == 7.0f && b.lo.y() == 7.8f;
    if (sideboard) continue;
    if (wall_with_new_door) {  // wall y 4.2..9 gets a doorway at y 6.5..7.5
      changed.push_back(box(6.0f, 4.2f, 0.0f, 6.2f, 6.5f, 2.6f));
      changed.push_back(box(6.0f, 7.5f, 0.0f, 6.2f, 9.0f, 2.6f));
      continue;
    }
    Box moved = b;
    if (b.lo.x() == 0.0f && b.lo.y() == 0.0f) moved.lo.y() += 1.5f, moved.hi.y() += 1.5f;  // cabinet
    if (b.lo.x() >= 10.5f && b.hi.x() <= 12.5f && b.hi.z() <= 0.8f)
      moved.lo.x() -= 1.5f, moved.hi.x() -= 1.5f;  // table
    changed.push_back(moved);
  }
  changed.push_back(box(11.0f, 4.0f, 0.0f, 11.6f, 4.6f, 1.0f));  // a box left on the way
  const TsdfMap map = test::make_office_map();
  const std::vector<Pose> truth = test::office_trajectory(70);
  const std::vector<Pose> odometry = test::drifting_odometry(truth, 13);
  const Scans scans = scan_route(changed, truth, 8);
  auto eval = cpu_evaluator(map);
  ParticleFilter filter(map, *eval, test::small_building_parameters(), 256);
  filter.initialize_local(truth[0]);
  const FilterRun r = run(filter, scans, truth, odometry);
  std::size_t converged = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const FilterStep& s = r.steps[i];
    const double error = test::translation_error(s.estimate.pose, truth[i]);
    EXPECT_LT(error, 0.3) << "step " << i;
    EXPECT_NE(s.state, TrackState::kLost) << "step " << i;
    converged += s.estimate.converged;
  }
  EXPECT_GE(converged, truth.size() * 8 / 10) << "a changed map is still the map";
}

// Two floors of one plan (the office, the upper one 3 m higher), a staircase in the south-east room rising
// through an opening in the slab. Only the staircase (seen from below: steps up to a hole; from above: a hole)
// tells the floors apart. The robot starts on the upper floor in the west room, with no prior: the filter must
// hold both floors while they look alike and never claim the wrong one.
std::vector<Box> two_floor_boxes() {
  std::vector<Box> boxes;
  const float lift = 3.0f;
  for (const Box& b : test::office_boxes()) {
    const bool floor = b.hi.z() <= 0.0f;
    const bool ceiling = b.lo.z() >= 2.6f;
    if (!ceiling) boxes.push_back(b);  // lower floor without its ceiling (the slab below replaces it)
    if (!floor) boxes.push_back(Box{b.lo + Eigen::Vector3f(0, 0, lift), b.hi + Eigen::Vector3f(0, 0, lift)});
  }
  // The slab between the floors (z 2.6..3.0) around the opening x 7..9, y 0.5..1.5.
  boxes.push_back(box(-0.2f, -0.2f, 2.6f, 7.0f, 9.2f, 3.0f));
  boxes.push_back(box(9.0f, -0.2f, 2.6f, 14.2f, 9.2f, 3.0f));
  boxes.push_back(box(7.0f, -0.2f, 2.6f, 9.0f, 0.5f, 3.0f));
  boxes.push_back(box(7.0f, 1.5f, 2.6f, 9.0f, 9.2f, 3.0f));
  for (int k = 0; k < 8; ++k) {  // steps up along +x to the opening
    const float x = 7.0f + 0.25f * static_cast<float>(k);
    boxes.push_back(box(x, 0.5f, 0.0f, x + 0.25f, 1.5f, 0.375f * static_cast<float>(k + 1)));
  }
  return boxes;
}

TEST(ChangedMap, TwoFloorsOfOnePlanNeverClaimTheWrongFloor) {
  const std::vector<Box> boxes = two_floor_boxes();
  const TsdfMap map =
      test::make_box_map(boxes, Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(14.2f, 9.2f, 5.8f));
  const std::vector<Pose> truth = route_through({{1.5, 6.0}, {1.5, 2.5}, {4.8, 3.6}, {8.0, 3.6}, {12.0, 3.5}}, 3.0);
  const FilterRun r = search_route(map, boxes, truth, 17, 9);
  bool both_floors = false;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const FilterStep& s = r.steps[i];
    const double error = test::translation_error(s.estimate.pose, truth[i]);
    if (s.estimate.converged) {
      EXPECT_LT(error, 0.3) << "converged on the wrong place (floor) at step " << i;
    }
    double upper = 0.0, lower = 0.0;
    for (const Place& h : s.estimate.places) {
      const double dz = h.pose.translation().z() - truth[i].translation().z();
      if (std::abs(dz) < 0.5) upper += h.weight;
      if (std::abs(dz + 3.0) < 0.5) lower += h.weight;
    }
    if (i >= 3 && truth[i].translation().x() < 4.0) {
      EXPECT_FALSE(s.estimate.converged) << "step " << i << ": the floors look the same here";
      if (upper > 0.01 && lower > 0.01) both_floors = true;
    }
  }
  EXPECT_TRUE(both_floors) << "the belief never held both floors while they looked alike";
  // The route's glimpse of the staircase does not settle the floor in this run (measured: the last estimate is on
  // the lower floor, not converged); what must hold is that the filter never claims a floor it cannot tell.
  const FilterStep& last = r.steps.back();
  EXPECT_TRUE(!last.estimate.converged || test::translation_error(last.estimate.pose, truth.back()) < 0.3);
}

}  // namespace
}  // namespace tsdf_mcl
