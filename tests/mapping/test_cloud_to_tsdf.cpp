// build_map_from_cloud against analytic signed distances: a plane, a room, a room split by a thin wall, a two-sided
// sheet; orientation with and without a trajectory; bad points; the memory budget.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::CloudMapOptions;
using tsdf_mcl::CloudMapReport;
using tsdf_mcl::TsdfMap;

namespace {

// Points on the axis-aligned rectangle spanned by `a` (fixed coordinate `axis` = `at`), spacing h, with noise.
void sample_rect(std::vector<Vector3f>& out, int axis, float at, const Eigen::Vector2f& lo, const Eigen::Vector2f& hi,
                 float h, std::mt19937& rng, float noise = 0.005f) {
  std::normal_distribution<float> n(0.0f, noise);
  for (float u = lo.x(); u <= hi.x() + 1e-4f; u += h) {
    for (float v = lo.y(); v <= hi.y() + 1e-4f; v += h) {
      Vector3f p;
      p[axis] = at + n(rng);
      p[(axis + 1) % 3] = u;
      p[(axis + 2) % 3] = v;
      out.push_back(p);
    }
  }
}

// The inner faces of the room [lo, hi].
std::vector<Vector3f> room(const Vector3f& lo, const Vector3f& hi, float h, std::mt19937& rng) {
  std::vector<Vector3f> out;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (float at : {lo[axis], hi[axis]}) {
      sample_rect(out, axis, at, {lo[u], lo[v]}, {hi[u], hi[v]}, h, rng);
    }
  }
  return out;
}

// Signed distance inside the room [lo, hi] seen from inside: positive inside, negative in its walls.
float room_distance(const Vector3f& p, const Vector3f& lo, const Vector3f& hi) {
  const Vector3f c = 0.5f * (lo + hi), half = 0.5f * (hi - lo);
  const Vector3f q = (p - c).cwiseAbs() - half;
  return -(q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f));
}

std::vector<Vector3f> loop(const Vector3f& centre, float radius, int n) {
  std::vector<Vector3f> out;
  for (int k = 0; k < n; ++k) {
    const float a = 6.2831853f * static_cast<float>(k) / static_cast<float>(n);
    out.push_back(centre + radius * Vector3f(std::cos(a), std::sin(a), 0.0f));
  }
  return out;
}

template <typename F>
void for_each_voxel(const TsdfMap& map, F&& f) {
  const Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) f(Vector3i(x, y, z));
}

struct RoomCheck {
  std::size_t band = 0, band_known = 0, band_close = 0, wrong_sign = 0, inside_far = 0, inside_free = 0,
              outside_positive = 0;
};

// Compares a map of the room [lo, hi] with the room's distance: magnitudes in the band, signs everywhere.
RoomCheck check_room(const TsdfMap& map, const Vector3f& lo, const Vector3f& hi) {
  RoomCheck c;
  const float trunc = map.truncation(), vs = map.voxel_size();
  for_each_voxel(map, [&](const Vector3i& v) {
    const float d = room_distance(map.center_of(v), lo, hi);
    const std::optional<float> got = map.distance(v);
    if (std::abs(d) < trunc - vs) {
      ++c.band;
      if (got) {
        ++c.band_known;
        c.band_close += std::abs(*got - d) <= vs;
      }
    } else if (d > 0.0f) {
      ++c.inside_far;
      c.inside_free += got && *got > 0.0f;
    }
    if (got && std::abs(d) > vs && (*got > 0.0f) != (d > 0.0f)) {
      ++c.wrong_sign;
      if (c.wrong_sign < 10) {
        const Vector3f p = map.center_of(v);
        std::printf("wrong sign at %.2f %.2f %.2f: %f, true %f\n", static_cast<double>(p.x()),
                    static_cast<double>(p.y()), static_cast<double>(p.z()), static_cast<double>(*got),
                    static_cast<double>(d));
      }
    }
    if (got && d<-trunc&& * got> 0.0f) ++c.outside_positive;
  });
  return c;
}

TEST(CloudToTsdf, PlaneMatchesAnalyticDistances) {
  std::mt19937 rng(1);
  std::vector<Vector3f> cloud;
  sample_rect(cloud, 2, 0.0f, {-2, -2}, {2, 2}, 0.03f, rng);
  CloudMapOptions o;
  o.voxel_size = 0.1f;
  o.truncation = 0.3f;
  o.trajectory = loop({0, 0, 1}, 1.0f, 16);
  CloudMapReport report;
  const TsdfMap map = tsdf_mcl::build_map_from_cloud(cloud, o, {}, &report);
  EXPECT_EQ(report.input_points, cloud.size());
  EXPECT_EQ(report.used_points, cloud.size());
  EXPECT_GT(report.oriented_by_trajectory, report.voxels * 9 / 10);
  EXPECT_GT(report.surface_points, cloud.size() * 95 / 100);
  for (int x = -12; x <= 12; x += 3) {
    for (int z = -2; z <= 2; ++z) {
      const auto d = map.distance({x, 4, z});
      ASSERT_TRUE(d.has_value()) << x << " " << z;
      EXPECT_NEAR(*d, 0.1f * static_cast<float>(z), 0.02f) << x << " " << z;
    }
    // The rest of the blocks near the floor at +-truncation, free space where the sight lines ran, unknown under the
    // floor's blocks.
    for (const auto& [z, d] : {std::pair{-6, -0.3f}, std::pair{6, 0.3f}, std::pair{9, 0.3f}}) {
      const auto got = map.distance({x, 4, z});
      ASSERT_TRUE(got.has_value()) << x << " " << z;
      EXPECT_NEAR(*got, d, 1e-3f) << x << " " << z;
    }
    EXPECT_FALSE(map.distance({x, 4, -10}).has_value()) << x;
  }
}

class CloudRoom : public ::testing::TestWithParam<bool> {};

TEST_P(CloudRoom, RoomMatchesAnalyticDistances) {
  const bool with_trajectory = GetParam();
  std::mt19937 rng(2);
  const Vector3f lo(0, 0, 0), hi(3.2f, 2.4f, 2.5f);
  const std::vector<Vector3f> cloud = room(lo, hi, 0.025f, rng);
  CloudMapOptions o;
  o.voxel_size = 0.1f;
  o.truncation = 0.3f;
  if (with_trajectory) o.trajectory = loop({1.6f, 1.2f, 1.0f}, 0.6f, 12);
  CloudMapReport report;
  const TsdfMap map = tsdf_mcl::build_map_from_cloud(cloud, o, {}, &report);
  EXPECT_EQ(report.isolated_points, 0u);
  if (with_trajectory) {
    EXPECT_GT(report.oriented_by_trajectory, report.planar * 8 / 10) << tsdf_mcl::describe(report);
  } else {
    EXPECT_GT(report.oriented_by_visibility, report.planar / 10) << tsdf_mcl::describe(report);
    EXPECT_EQ(report.oriented_by_trajectory, 0u);
  }
  EXPECT_GT(report.surface_points, report.used_points * 9 / 10) << tsdf_mcl::describe(report);
  const RoomCheck c = check_room(map, lo, hi);
  // Edges and corners of the room are unsigned: their voxels may stay unknown; the rest matches within a voxel.
  EXPECT_GT(c.band_known, c.band * 85 / 100) << tsdf_mcl::describe(report);
  EXPECT_GT(c.band_close, c.band_known * 97 / 100);
  EXPECT_EQ(c.wrong_sign, 0u);
  EXPECT_EQ(c.outside_positive, 0u);
  EXPECT_GT(c.inside_free, c.inside_far * 9 / 10);
}

INSTANTIATE_TEST_SUITE_P(Cloud, CloudRoom, ::testing::Bool(), [](const ::testing::TestParamInfo<bool>& p) {
  return p.param ? "WithTrajectory" : "WithoutTrajectory";
});

class CloudThinWall : public ::testing::TestWithParam<bool> {};

// Two rooms either side of a 0.2 m wall, both faces scanned: each face faces its own room, the wall's inside is
// negative, and neither side has a positive hole.
TEST_P(CloudThinWall, BothFacesKeepTheirSides) {
  const bool with_trajectory = GetParam();
  std::mt19937 rng(3);
  const Vector3f lo(0, 0, 0), hi(4.0f, 2.4f, 2.4f);
  std::vector<Vector3f> cloud = room(lo, hi, 0.02f, rng);
  for (float x : {1.9f, 2.1f}) sample_rect(cloud, 0, x, {0, 0}, {2.4f, 2.4f}, 0.02f, rng);
  CloudMapOptions o;
  o.voxel_size = 0.05f;
  o.truncation = 0.3f;
  if (with_trajectory) {
    o.trajectory = loop({1.0f, 1.2f, 1.0f}, 0.4f, 8);
    const auto right = loop({3.0f, 1.2f, 1.0f}, 0.4f, 8);
    o.trajectory.insert(o.trajectory.end(), right.begin(), right.end());
  }
  CloudMapReport report;
  const TsdfMap map = tsdf_mcl::build_map_from_cloud(cloud, o, {}, &report);
  const auto wall = [](float x) {
    return std::min(std::abs(x - 1.9f), std::abs(x - 2.1f)) * (x > 1.9f && x < 2.1f ? -1.0f : 1.0f);
  };
  for (int y = 12; y <= 36; y += 6) {
    for (int z = 12; z <= 36; z += 6) {
      for (int x = 34; x <= 46; ++x) {
        const float truth = wall(0.05f * static_cast<float>(x));
        const auto d = map.distance({x, y, z});
        ASSERT_TRUE(d.has_value()) << x << " " << y << " " << z << "\n" << tsdf_mcl::describe(report);
        EXPECT_NEAR(*d, truth, 0.03f) << x << " " << y << " " << z;
      }
    }
  }
}

// A drifted double wall: the room's x = 0 wall scanned twice, 3 cm apart, both facing the room. One surface between
// the sheets: positive in front, negative behind, no positive layer between or behind them. (6 cm apart passes too;
// past 1.5 voxels the sheets are separate surfaces.)
TEST_P(CloudThinWall, DoubleWallFromDriftHasNoHoles) {
  const bool with_trajectory = GetParam();
  std::mt19937 rng(7);
  const Vector3f lo(0, 0, 0), hi(3.2f, 2.4f, 2.4f);
  std::vector<Vector3f> cloud = room(lo, hi, 0.02f, rng);
  sample_rect(cloud, 0, -0.03f, {0, 0}, {2.4f, 2.4f}, 0.02f, rng);
  CloudMapOptions o;
  o.voxel_size = 0.05f;
  if (with_trajectory) o.trajectory = loop({1.6f, 1.2f, 1.0f}, 0.6f, 12);
  CloudMapReport report;
  const TsdfMap map = tsdf_mcl::build_map_from_cloud(cloud, o, {}, &report);
  for (int y = 8; y <= 40; y += 8) {
    for (int z = 8; z <= 40; z += 8) {
      for (int x = -5; x <= 6; ++x) {
        const float truth = 0.05f * static_cast<float>(x) + 0.015f;
        const auto d = map.distance({x, y, z});
        ASSERT_TRUE(d.has_value()) << x << " " << y << " " << z << "\n" << tsdf_mcl::describe(report);
        if (std::abs(truth) > 0.05f) {
          EXPECT_EQ(*d > 0.0f, truth > 0.0f) << x << " " << y << " " << z << ": " << *d;
          EXPECT_NEAR(*d, truth, 0.05f) << x << " " << y << " " << z;
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Cloud, CloudThinWall, ::testing::Bool(), [](const ::testing::TestParamInfo<bool>& p) {
  return p.param ? "WithTrajectory" : "WithoutTrajectory";
});

// A single sheet of points seen from both sides is two-sided: distance only, positive on both sides.
TEST(CloudToTsdf, SheetSeenFromBothSidesIsTwoSided) {
  std::mt19937 rng(4);
  const Vector3f lo(0, 0, 0), hi(4.0f, 2.4f, 2.4f);
  std::vector<Vector3f> cloud = room(lo, hi, 0.025f, rng);
  sample_rect(cloud, 0, 2.0f, {0.5f, 0.0f}, {1.9f, 1.5f}, 0.025f, rng, 0.002f);  // a free-standing screen
  CloudMapOptions o;
  o.voxel_size = 0.1f;
  o.trajectory = loop({1.0f, 1.2f, 1.0f}, 0.4f, 8);
  const auto right = loop({3.0f, 1.2f, 1.0f}, 0.4f, 8);
  o.trajectory.insert(o.trajectory.end(), right.begin(), right.end());
  CloudMapReport report;
  const TsdfMap map = tsdf_mcl::build_map_from_cloud(cloud, o, {}, &report);
  EXPECT_GT(report.two_sided, 100u) << tsdf_mcl::describe(report);
  for (int x = 17; x <= 23; ++x) {
    const auto d = map.distance({x, 12, 8});
    ASSERT_TRUE(d.has_value()) << x;
    EXPECT_GE(*d, 0.0f) << x;
    EXPECT_NEAR(*d, std::max(0.0f, std::abs(0.1f * static_cast<float>(x) - 2.0f) - 0.05f), 0.06f) << x;
  }
}

// NaNs, duplicates and isolated outliers leave the map as the clean cloud makes it, and are counted.
TEST(CloudToTsdf, BadPointsAreDroppedAndCounted) {
  std::mt19937 rng(5);
  std::vector<Vector3f> clean;
  sample_rect(clean, 2, 0.0f, {-1, -1}, {1, 1}, 0.03f, rng);
  std::vector<Vector3f> dirty = clean;
  dirty.insert(dirty.end(), clean.begin(), clean.end());  // every point twice
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 50; ++k) dirty.emplace_back(nan, 0.0f, 1.0f);
  dirty.emplace_back(inf, 0.0f, 0.0f);
  dirty.emplace_back(1e30f, 0.0f, 0.0f);  // beyond the map's coordinate range
  for (int k = 0; k < 20; ++k) dirty.emplace_back(0.1f * k - 1.0f, 0.5f, 1.0f + 0.4f * (k % 3));  // isolated
  CloudMapOptions o;
  o.voxel_size = 0.1f;
  o.trajectory = loop({0, 0, 1.5f}, 0.5f, 8);
  CloudMapReport clean_report, dirty_report;
  const TsdfMap a = tsdf_mcl::build_map_from_cloud(clean, o, {}, &clean_report);
  const TsdfMap b = tsdf_mcl::build_map_from_cloud(dirty, o, {}, &dirty_report);
  EXPECT_EQ(dirty_report.input_points, dirty.size());
  EXPECT_EQ(dirty_report.non_finite, 51u);
  EXPECT_EQ(dirty_report.out_of_range, 1u);
  EXPECT_EQ(dirty_report.isolated_points, 20u);
  EXPECT_EQ(dirty_report.used_points, 2 * clean.size());
  EXPECT_EQ(dirty_report.voxels, clean_report.voxels);
  for (int x = -8; x <= 8; x += 2) {
    for (int z = -3; z <= 3; ++z) {
      const auto da = a.distance({x, 2, z}), db = b.distance({x, 2, z});
      ASSERT_EQ(da.has_value(), db.has_value()) << x << " " << z;
      if (da) {
        EXPECT_NEAR(*da, *db, 0.01f) << x << " " << z;
      }
    }
  }
}

TEST(CloudToTsdf, HugeExtentStopsAtTheBudget) {
  std::mt19937 rng(6);
  std::vector<Vector3f> cloud;
  sample_rect(cloud, 2, 0.0f, {0, 0}, {1, 1}, 0.03f, rng);
  sample_rect(cloud, 2, 60.0f, {600, 600}, {601, 601}, 0.03f, rng);
  CloudMapOptions o;
  o.voxel_size = 0.1f;
  o.max_memory_bytes = std::uint64_t{64} << 20;
  try {
    tsdf_mcl::build_map_from_cloud(cloud, o);
    FAIL() << "no error";
  } catch (const tsdf_mcl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget of 64 MiB"), std::string::npos) << e.what();
  }
  std::vector<Vector3f> nothing(10, Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_THROW(tsdf_mcl::build_map_from_cloud(nothing, CloudMapOptions{}), tsdf_mcl::Error);
}

}  // namespace
