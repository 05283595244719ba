// scan_fit.hpp: map evidence per scan point (RayFit: unknown is unknown) and paired evidence between two poses on the
// points both observe.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "filter_test_scene.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {
namespace {

using test::Box;
using test::box;

// Two rooms side by side (x 0..6 and 6.2..12, a door in the wall between at y 2..3), a thick solid block in the
// west room. The map holds the west room only: the east room is space the mapping run never observed.
std::vector<Box> two_rooms() {
  return {box(-0.2f, -0.2f, -0.2f, 12.2f, 6.2f, 0.0f), box(-0.2f, -0.2f, 2.6f, 12.2f, 6.2f, 2.8f),
          box(-0.2f, -0.2f, 0.0f, 0.0f, 6.2f, 2.6f),   box(12.0f, -0.2f, 0.0f, 12.2f, 6.2f, 2.6f),
          box(-0.2f, -0.2f, 0.0f, 12.2f, 0.0f, 2.6f),  box(-0.2f, 6.0f, 0.0f, 12.2f, 6.2f, 2.6f),
          box(6.0f, 0.0f, 0.0f, 6.2f, 2.0f, 2.6f),     box(6.0f, 3.0f, 0.0f, 6.2f, 6.0f, 2.6f),
          box(2.0f, 4.0f, 0.0f, 4.0f, 6.0f, 2.6f)};
}
TsdfMap west_room_map() {
  return test::make_box_map(two_rooms(), Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(6.2f, 6.2f, 2.8f));
}

TEST(MapEvidence, UnobservedOnlyWhereTheMapNeverLooked) {
  const TsdfMap map = west_room_map();
  const Pose west = pose_from_xyz_rpy(3.0, 2.0, 1.0, 0.0, 0.0, 0.0);
  const Pose east = pose_from_xyz_rpy(9.0, 2.5, 1.0, 0.0, 0.0, 0.0);
  const std::vector<Eigen::Vector3f> points = {
      Eigen::Vector3f(-3.0f, 0.0f, 0.0f),  // west wall: an inlier
      Eigen::Vector3f(0.0f, 1.5f, 0.0f),   // 1.5 m in front of the block: observed free space, no inlier
      Eigen::Vector3f(0.0f, 3.0f, 0.0f),   // 1 m deep inside the block (unknown beyond the band): a miss
      Eigen::Vector3f(6.0f, 0.5f, 0.0f),   // through the door into the east room: unobserved
  };
  std::vector<std::uint8_t> observed;
  const RayFit fit = ray_fit(map, west, points, 0.2f, 0.4f, &observed);
  EXPECT_EQ(observed, (std::vector<std::uint8_t>{1, 1, 1, 0}));
  EXPECT_EQ(fit.observed, 3u);
  EXPECT_EQ(fit.inliers, 1u);
  EXPECT_DOUBLE_EQ(fit.coverage(), 0.75);
  EXPECT_DOUBLE_EQ(fit.inlier_ratio(), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(fit.absolute_inlier_ratio(), 0.25);

  // A sensor in the unmapped room: nothing it sees there is evidence.
  const std::vector<Eigen::Vector3f> around = {Eigen::Vector3f(2.9f, 0.0f, 0.0f), Eigen::Vector3f(0.0f, 3.4f, 0.0f),
                                               Eigen::Vector3f(0.0f, 0.0f, -1.0f)};
  const RayFit there = ray_fit(map, east, around, 0.2f, 0.4f, &observed);
  EXPECT_EQ(there.observed, 0u);
  EXPECT_DOUBLE_EQ(there.coverage(), 0.0);
  EXPECT_DOUBLE_EQ(there.inlier_ratio(), 0.0);
}

// ray_fit and drop_frontier_points split a scan over the OpenMP threads: the counts and the mask must not depend on
// how many there are (a dense ring of rays into both rooms, the door and the block: every kind of ray).
TEST(MapEvidence, TheSameOnAnyNumberOfThreads) {
  const TsdfMap map = west_room_map();
  const Pose at = pose_from_xyz_rpy(4.5, 2.2, 1.2, 0.02, -0.03, 0.4);
  const double deg = std::acos(-1.0) / 180.0;
  std::vector<Eigen::Vector3f> points;
  for (int e = -8; e <= 8; ++e) {
    for (int a = 0; a < 72; ++a) {
      const double azimuth = a * 5.0 * deg;
      const double elevation = e * 4.0 * deg;
      const float range = 1.0f + 0.37f * static_cast<float>((a * 7 + e * 3 + 40) % 17);
      points.emplace_back(range * Eigen::Vector3f(static_cast<float>(std::cos(elevation) * std::cos(azimuth)),
                                                  static_cast<float>(std::cos(elevation) * std::sin(azimuth)),
                                                  static_cast<float>(std::sin(elevation))));
    }
  }
  const auto fit_with = [&](int threads, std::vector<std::uint8_t>& observed, std::size_t& dropped) {
    omp_set_num_threads(threads);
    const RayFit fit = ray_fit(map, at, points, 0.2f, 0.4f, &observed);
    dropped = drop_frontier_points(map, at, points, 0.3f, observed);
    return fit;
  };
  const int threads = omp_get_max_threads();
  std::vector<std::uint8_t> one_mask, two_mask;
  std::size_t one_dropped = 0, two_dropped = 0;
  const RayFit one = fit_with(1, one_mask, one_dropped);
  const RayFit two = fit_with(std::max(2, threads), two_mask, two_dropped);
  omp_set_num_threads(threads);
  ASSERT_GT(points.size(), 1000u);
  EXPECT_GT(one.observed, 0u);
  EXPECT_GT(one.inliers, 0u);
  EXPECT_LT(one.observed, points.size()) << "some rays must end in the unmapped room";
  EXPECT_EQ(one.observed, two.observed);
  EXPECT_EQ(one.inliers, two.inliers);
  EXPECT_EQ(one.see_through, two.see_through);
  EXPECT_EQ(one.back_faces, two.back_faces);
  EXPECT_EQ(one_mask, two_mask);
  EXPECT_EQ(one_dropped, two_dropped);
}

// A wall whose west face (x = 0) the mapping run saw from the west only, as scan integration leaves it: observed
// free space west of it, its band reaching 0.3 m through it (the distance falling eastwards), unknown beyond.
TsdfMap wall_seen_from_the_west() {
  TsdfMap map = TsdfMap::covering(0.05f, 0.3f, Eigen::Vector3f(-2.0f, -1.0f, -1.0f), Eigen::Vector3f(2.0f, 1.0f, 1.0f));
  for (int x = -40; x <= 6; ++x) {
    for (int y = -20; y <= 20; ++y) {
      for (int z = -20; z <= 20; ++z) {
        const float d = std::min(-0.05f * static_cast<float>(x), 0.3f);
        map.set_distance(Eigen::Vector3i(x, y, z), d);
      }
    }
  }
  return map;
}

TEST(MapEvidence, TheFarFaceOfAWallSeenFromBehindIsUnobserved) {
  const TsdfMap map = wall_seen_from_the_west();
  const Pose west = pose_from_xyz_rpy(-1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  const Pose east = pose_from_xyz_rpy(1.0, 0.0, 0.0, 0.0, 0.0, M_PI);  // facing west, in unmapped space
  std::vector<std::uint8_t> observed;
  // From the west: the face itself is an inlier; points behind it are misses (the ray crossed the face the map
  // holds), however near.
  const RayFit front = ray_fit(
      map, west,
      {Eigen::Vector3f(0.98f, 0.0f, 0.0f), Eigen::Vector3f(1.1f, 0.0f, 0.0f), Eigen::Vector3f(1.25f, 0.0f, 0.0f)}, 0.2f,
      0.4f, &observed);
  EXPECT_EQ(observed, (std::vector<std::uint8_t>{1, 1, 1}));
  EXPECT_EQ(front.inliers, 2u);
  EXPECT_EQ(front.back_faces, 0u);
  // From the east, the wall's east face at x = 0.2 (its distance -0.2, less than the band) and a point 0.1 m into
  // it: the distance grows towards the sensor, the map holds no face turned to it. Unobserved, neither inlier nor
  // miss.
  const RayFit back =
      ray_fit(map, east, {Eigen::Vector3f(0.8f, 0.0f, 0.0f), Eigen::Vector3f(0.9f, 0.0f, 0.0f)}, 0.2f, 0.4f, &observed);
  EXPECT_EQ(observed, (std::vector<std::uint8_t>{0, 0}));
  EXPECT_EQ(back.observed, 0u);
  EXPECT_EQ(back.back_faces, 2u);
}

// A 5 x 4 m room mapped from the ground: the map holds it up to 1.6 m; the upper walls and the ceiling are space
// it never observed.
TsdfMap low_mapped_room() {
  const std::vector<Box> room = {box(-0.2f, -0.2f, -0.2f, 5.2f, 4.2f, 0.0f), box(-0.2f, -0.2f, 3.0f, 5.2f, 4.2f, 3.2f),
                                 box(-0.2f, -0.2f, 0.0f, 0.0f, 4.2f, 3.0f),  box(5.0f, -0.2f, 0.0f, 5.2f, 4.2f, 3.0f),
                                 box(-0.2f, -0.2f, 0.0f, 5.2f, 0.0f, 3.0f),  box(-0.2f, 4.0f, 0.0f, 5.2f, 4.2f, 3.0f)};
  return test::make_box_map(room, Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(5.2f, 4.2f, 1.6f), 0.05f, 0.3f);
}

TEST(MapEvidence, PointsAtTheFrontierOfTheObservedSpaceAreNoEvidence) {
  const TsdfMap map = low_mapped_room();
  const Pose pose = pose_from_xyz_rpy(2.5, 2.0, 1.0, 0.0, 0.0, 0.0);
  const std::vector<Eigen::Vector3f> points = {
      Eigen::Vector3f(2.5f, 0.0f, 0.5f),    // east wall at 1.5 m, 0.1 m below its unobserved upper part: frontier
      Eigen::Vector3f(2.5f, 0.0f, 0.0f),    // east wall at 1.0 m
      Eigen::Vector3f(0.0f, -2.0f, -0.6f),  // south wall at 0.4 m
      Eigen::Vector3f(0.0f, 0.0f, -1.0f),   // the floor
      Eigen::Vector3f(2.9f, 0.0f, 0.0f),    // behind the east wall: a miss the map judges, not a frontier
  };
  std::vector<std::uint8_t> observed;
  ray_fit(map, pose, points, 0.2f, 0.4f, &observed);
  ASSERT_EQ(observed, (std::vector<std::uint8_t>{1, 1, 1, 1, 1}));
  EXPECT_EQ(drop_frontier_points(map, pose, points, map.truncation(), observed), 1u);
  EXPECT_EQ(observed, (std::vector<std::uint8_t>{0, 1, 1, 1, 1}));
  // Unobserved points stay unobserved, and no reach means no frontier.
  std::vector<std::uint8_t> none(points.size(), 0);
  EXPECT_EQ(drop_frontier_points(map, pose, points, map.truncation(), none), 0u);
  EXPECT_EQ(none, std::vector<std::uint8_t>(points.size(), 0));
  ray_fit(map, pose, points, 0.2f, 0.4f, &observed);
  EXPECT_EQ(drop_frontier_points(map, pose, points, 0.0f, observed), 0u);
}

// A room mapped whole, but for a patch of its ceiling's surface voxels (z = 3.0), left unknown as grazing rays
// through a door leave them (the voxels in front of the surface and above it known). A point in that hole is no
// evidence: with the voxel known it would be an inlier. Points on the intact ceiling and behind a wall stay.
TEST(MapEvidence, AHoleInASurfaceIsNoEvidence) {
  const std::vector<Box> room = {box(-0.2f, -0.2f, -0.2f, 5.2f, 4.2f, 0.0f), box(-0.2f, -0.2f, 3.0f, 5.2f, 4.2f, 3.6f),
                                 box(-0.2f, -0.2f, 0.0f, 0.0f, 4.2f, 3.0f),  box(5.0f, -0.2f, 0.0f, 5.6f, 4.2f, 3.0f),
                                 box(-0.2f, -0.2f, 0.0f, 5.2f, 0.0f, 3.0f),  box(-0.2f, 4.0f, 0.0f, 5.2f, 4.2f, 3.0f)};
  TsdfMap map =
      test::make_box_map(room, Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(5.6f, 4.2f, 3.6f), 0.05f, 0.3f);
  const Eigen::Vector3i lo = map.voxel_of(Eigen::Vector3f(3.3f, 1.8f, 3.0f));
  const Eigen::Vector3i hi = map.voxel_of(Eigen::Vector3f(3.7f, 2.2f, 3.0f));
  for (int x = lo.x(); x <= hi.x(); ++x) {
    for (int y = lo.y(); y <= hi.y(); ++y) map.set_unknown(Eigen::Vector3i(x, y, lo.z()));
  }
  // Beyond the east wall's band (x from 5.3 on) the map holds nothing.
  const Eigen::Vector3i east_lo = map.voxel_of(Eigen::Vector3f(5.35f, -0.2f, -0.2f));
  const Eigen::Vector3i east_hi = map.voxel_of(Eigen::Vector3f(5.6f, 4.2f, 3.6f));
  for (int x = east_lo.x(); x <= east_hi.x(); ++x) {
    for (int y = east_lo.y(); y <= east_hi.y(); ++y) {
      for (int z = east_lo.z(); z <= east_hi.z(); ++z) map.set_unknown(Eigen::Vector3i(x, y, z));
    }
  }
  const Pose pose = pose_from_xyz_rpy(2.5, 2.0, 1.5, 0.0, 0.0, 0.0);
  const std::vector<Eigen::Vector3f> points = {
      Eigen::Vector3f(1.0f, 0.0f, 1.5f),   // the ceiling in the hole
      Eigen::Vector3f(-1.0f, 0.0f, 1.5f),  // the intact ceiling
      Eigen::Vector3f(3.0f, 0.0f, 0.0f),   // 0.5 m into the east wall, beyond its band: a miss
  };
  ASSERT_EQ(map.quantized(map.voxel_of(Eigen::Vector3f(3.5f, 2.0f, 3.0f))), TsdfMap::kUnknownValue);
  ASSERT_EQ(map.quantized(map.voxel_of(Eigen::Vector3f(5.5f, 2.0f, 1.5f))), TsdfMap::kUnknownValue);
  std::vector<std::uint8_t> observed(points.size(), 1);
  EXPECT_EQ(drop_frontier_points(map, pose, points, map.truncation(), observed), 1u);
  EXPECT_EQ(observed, (std::vector<std::uint8_t>{0, 1, 1}));
}

// The same room whose walls' top band (from 1.3 m up) the mapping run saw from afar, at grazing angles: the map
// holds them 0.25 m off. Seen from 0.3 m lower, the upper walls' points land on the accurate lower band, and on the
// points both heights observe the lower pose explained the scan better by the frontier's points alone.
TEST(PairedEvidence, TheFrontierDoesNotDecideBetweenHeights) {
  TsdfMap map = low_mapped_room();
  const Eigen::Vector3i lo = map.voxel_of(Eigen::Vector3f(-0.2f, -0.2f, 1.3f));
  const Eigen::Vector3i hi = map.voxel_of(Eigen::Vector3f(5.2f, 4.2f, 1.6f));
  for (int x = lo.x(); x <= hi.x(); ++x) {
    for (int y = lo.y(); y <= hi.y(); ++y) {
      for (int z = lo.z(); z <= hi.z(); ++z) {
        const Eigen::Vector3i v(x, y, z);
        const std::optional<float> d = map.distance(v);
        if (d) map.set_distance(v, std::min(*d + 0.25f, map.truncation()));
      }
    }
  }
  std::vector<Eigen::Vector3f> points;  // a VLP-16-like fan of the walls from (2.5, 2, 1.5)
  for (int ring = 0; ring < 16; ++ring) {
    const double elevation = (-15.0 + 2.0 * ring) * M_PI / 180.0;
    for (int k = 0; k < 48; ++k) {
      const double azimuth = k * 2.0 * M_PI / 48.0;
      const Eigen::Vector3d dir(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                                std::sin(elevation));
      double t = 1e9;
      if (dir.x() > 1e-6) t = std::min(t, 2.5 / dir.x());
      if (dir.x() < -1e-6) t = std::min(t, -2.5 / dir.x());
      if (dir.y() > 1e-6) t = std::min(t, 2.0 / dir.y());
      if (dir.y() < -1e-6) t = std::min(t, -2.0 / dir.y());
      points.push_back((t * dir).cast<float>());
    }
  }
  const Pose truth = pose_from_xyz_rpy(2.5, 2.0, 1.5, 0.0, 0.0, 0.0);
  const Pose low = pose_from_xyz_rpy(2.5, 2.0, 1.2, 0.0, 0.0, 0.0);
  const EndpointModel model;
  std::vector<double> log_truth, log_low;
  point_log_likelihoods(map, model, truth.translation().cast<float>(), Eigen::Quaternionf::Identity(), points,
                        log_truth);
  point_log_likelihoods(map, model, low.translation().cast<float>(), Eigen::Quaternionf::Identity(), points, log_low);
  std::vector<std::uint8_t> obs_truth, obs_low;
  ray_fit(map, truth, points, 0.2f, 0.4f, &obs_truth);
  ray_fit(map, low, points, 0.2f, 0.4f, &obs_low);
  const double with_frontier = paired_evidence(log_low, obs_low, log_truth, obs_truth, 0.5).sum;
  EXPECT_GT(with_frontier, 5.0) << "the frontier's points favour the lower pose";
  drop_frontier_points(map, truth, points, map.truncation(), obs_truth);
  drop_frontier_points(map, low, points, map.truncation(), obs_low);
  const PairedEvidence without = paired_evidence(log_low, obs_low, log_truth, obs_truth, 0.5);
  EXPECT_GT(without.shared, 100u);
  EXPECT_LT(std::abs(without.sum), 1.0);
}

TEST(PairedEvidence, CountsOnlyPointsObservedUnderBothPoses) {
  const std::vector<double> a = {-1.0, -1.0, -5.0, -9.0, 0.0};
  const std::vector<double> b = {-2.0, -1.0, -1.0, 0.0, -9.0};
  const std::vector<std::uint8_t> oa = {1, 1, 1, 0, 1};
  const std::vector<std::uint8_t> ob = {1, 1, 1, 1, 0};
  const PairedEvidence e = paired_evidence(a, oa, b, ob, 0.5);
  EXPECT_EQ(e.shared, 3u);
  EXPECT_DOUBLE_EQ(e.sum, 0.5 + 0.0 - 3.5);  // beyond the dead band, the sign kept
  const PairedEvidence reverse = paired_evidence(b, ob, a, oa, 0.5);
  EXPECT_DOUBLE_EQ(reverse.sum, -e.sum);
  EXPECT_EQ(paired_evidence(a, oa, b, ob, 0.5).shared, paired_evidence(a, ob, b, oa, 0.5).shared);
}

// A pose that pushes scan points out of the map must not win by it: compared on the points both poses observe,
// the true pose explains them better.
TEST(PairedEvidence, APoseOffTheMapGainsNothing) {
  const TsdfMap map = west_room_map();
  const std::vector<Box> boxes = two_rooms();
  Rng rng(3);
  const Pose truth = pose_from_xyz_rpy(4.5, 2.5, 1.0, 0.0, 0.0, 0.3);
  const std::vector<Eigen::Vector3f> points = test::simulate_scan(boxes, truth, rng, 16, 90);
  Pose off = truth;
  off.translation().x() += 4.0;  // most of the room's points now land in the unobserved east room
  EndpointModel model;
  model.unknown_distance = map.truncation();
  std::vector<double> log_truth, log_off;
  std::vector<std::uint8_t> obs_truth, obs_off;
  const auto log_likelihoods = [&](const Pose& p, std::vector<double>& out) {
    point_log_likelihoods(map, model, p.translation().cast<float>(),
                          Eigen::Quaternionf(Eigen::Quaterniond(p.linear()).cast<float>()), points, out);
  };
  log_likelihoods(truth, log_truth);
  log_likelihoods(off, log_off);
  const RayFit fit_truth = ray_fit(map, truth, points, 0.2f, 0.4f, &obs_truth);
  const RayFit fit_off = ray_fit(map, off, points, 0.2f, 0.4f, &obs_off);
  EXPECT_GT(fit_truth.coverage(), 0.9);
  EXPECT_LT(fit_off.coverage(), 0.6);
  const PairedEvidence e = paired_evidence(log_off, obs_off, log_truth, obs_truth, 0.0);
  EXPECT_GT(e.shared, 0u);
  EXPECT_LT(e.sum, 0.0) << "the off-map pose explains the shared points worse";
}

}  // namespace
}  // namespace tsdf_mcl
