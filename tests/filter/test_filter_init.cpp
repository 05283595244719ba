#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "filter_test_scene.hpp"
#include "owned_particles.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/particle_init.hpp"

namespace tsdf_mcl {
namespace {

using test::OwnedParticles;

const TsdfMap& office() {
  static const TsdfMap map = test::make_office_map();
  return map;
}

// Height of the highest box top below p that covers p's x and y (the floor a ground robot stands on).
double floor_below(const Eigen::Vector3f& p) {
  double floor = -1e9;
  for (const test::Box& b : test::office_boxes()) {
    if (p.x() >= b.lo.x() && p.x() <= b.hi.x() && p.y() >= b.lo.y() && p.y() <= b.hi.y() && b.hi.z() <= p.z()) {
      floor = std::max(floor, static_cast<double>(b.hi.z()));
    }
  }
  return floor;
}

TEST(GlobalInit, PositionsLieInKnownFreeSpaceUniformly) {
  const TsdfMap& map = office();
  const FreeSpaceSampler sampler(map, GlobalInitOptions{});
  EXPECT_EQ(sampler.candidate_voxels(), map.stats().free_voxels);
  const std::size_t n = 20000;
  OwnedParticles p(n);
  sampler.sample(p.view, 0, n, 1, 0);
  std::size_t west = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3i v = map.voxel_of(p.view.position(i));
    const auto d = map.distance(v);
    ASSERT_TRUE(d.has_value()) << "particle " << i << " in unknown space";
    ASSERT_GT(*d, 0.0f) << "particle " << i << " inside a surface";
    ASSERT_NEAR(p.view.rotation(i).norm(), 1.0f, 1e-5f);
    if (p.view.x[i] < 6.0f) ++west;
  }
  // The share of samples west of x = 6 matches the share of free voxels there.
  std::size_t free_west = 0, free_all = 0;
  const Eigen::Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Eigen::Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) {
        const auto d = map.distance({x, y, z});
        if (!d || *d <= 0.0f) continue;
        ++free_all;
        if (map.center_of({x, y, z}).x() < 6.0f) ++free_west;
      }
  EXPECT_EQ(free_all, sampler.candidate_voxels());
  EXPECT_NEAR(static_cast<double>(west) / n, static_cast<double>(free_west) / static_cast<double>(free_all), 0.015);
}

TEST(GlobalInit, ClearanceAndHeightBandAboveTheFloor) {
  const TsdfMap& map = office();
  GlobalInitOptions o;
  o.min_clearance = 0.2;
  o.use_height_band = true;
  o.min_height = 0.6;
  o.max_height = 1.2;
  const FreeSpaceSampler sampler(map, o);
  const std::size_t n = 5000;
  OwnedParticles p(n);
  sampler.sample(p.view, 0, n, 2, 0);
  std::size_t above_furniture = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f pos = p.view.position(i);
    ASSERT_GE(*map.distance(map.voxel_of(pos)), 0.2f - map.quantization_step());
    // The floor is found per voxel column: look below the voxel centre, not the jittered position.
    const double floor = floor_below(map.center_of(map.voxel_of(pos)));
    const double height = pos.z() - floor;
    // Floor and voxel centres differ by up to one voxel; the jitter adds half of one.
    ASSERT_GE(height, 0.6 - 1.5 * map.voxel_size()) << "at " << pos.transpose();
    ASSERT_LE(height, 1.2 + 1.5 * map.voxel_size()) << "at " << pos.transpose();
    if (floor > 0.5) ++above_furniture;
  }
  // The band follows the floor below, furniture tops included (cabinet, table, sideboard, shelf).
  EXPECT_GT(above_furniture, 0u);

  o.min_height = 5.0;
  o.max_height = 6.0;
  EXPECT_THROW(FreeSpaceSampler(map, o), Error);
}

TEST(GlobalInit, RotationsUniformOverSo3OrWithinTheTiltBound) {
  const TsdfMap& map = office();
  const std::size_t n = 40000;
  OwnedParticles p(n);
  FreeSpaceSampler(map, GlobalInitOptions{}).sample(p.view, 0, n, 3, 0);
  // Uniform rotations: every axis of the sensor points uniformly over the sphere.
  double z_mean = 0.0, z_sq = 0.0, x_mean = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3f r = p.view.rotation(i).toRotationMatrix();
    z_mean += r(2, 2);
    z_sq += r(2, 2) * r(2, 2);
    x_mean += r(0, 0);
  }
  EXPECT_NEAR(z_mean / n, 0.0, 0.015);
  EXPECT_NEAR(z_sq / n, 1.0 / 3.0, 0.01);
  EXPECT_NEAR(x_mean / n, 0.0, 0.015);

  GlobalInitOptions o;
  o.max_tilt = 0.1;
  FreeSpaceSampler(map, o).sample(p.view, 0, n, 3, 0);
  std::size_t quadrant[4] = {0, 0, 0, 0};
  double cos_sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3f r = p.view.rotation(i).toRotationMatrix();
    const double tilt = std::acos(std::clamp(static_cast<double>(r(2, 2)), -1.0, 1.0));
    ASSERT_LE(tilt, 0.1 + 1e-4);
    cos_sum += r(2, 2);
    const double yaw = std::atan2(r(1, 0), r(0, 0));
    ++quadrant[static_cast<int>(std::floor((yaw + M_PI) / (M_PI / 2))) & 3];
  }
  // cos(tilt) uniform on [cos 0.1, 1]: its mean is the midpoint.
  EXPECT_NEAR(cos_sum / n, 0.5 * (1.0 + std::cos(0.1)), 1e-4);
  for (std::size_t q : quadrant) EXPECT_NEAR(static_cast<double>(q) / n, 0.25, 0.015);
}

TEST(LocalInit, GaussianAroundThePose) {
  const std::size_t n = 20000;
  OwnedParticles p(n);
  const Pose mean = pose_from_xyz_rpy(3.0, 4.0, 1.0, 0.0, 0.0, 2.0);
  LocalInitSpread s;
  s.sigma_xy = 0.3;
  s.sigma_z = 0.05;
  s.sigma_yaw = 0.2;
  s.sigma_roll_pitch = 0.02;
  sample_local(p.view, n, mean, s, 5, 0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
  double yaw_sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = p.view.position(i).cast<double>() - mean.translation();
    sum += d;
    sq += d.cwiseProduct(d);
    const Eigen::Vector3d r = rpy_of(p.view.rotation(i).cast<double>().toRotationMatrix());
    yaw_sq += std::pow(std::remainder(r.z() - 2.0, 2 * M_PI), 2);
  }
  EXPECT_LT((sum / n).norm(), 0.01);
  EXPECT_NEAR(std::sqrt(sq.x() / n), 0.3, 0.01);
  EXPECT_NEAR(std::sqrt(sq.y() / n), 0.3, 0.01);
  EXPECT_NEAR(std::sqrt(sq.z() / n), 0.05, 0.002);
  EXPECT_NEAR(std::sqrt(yaw_sq / n), 0.2, 0.008);
  s.sigma_xy = -1.0;
  EXPECT_THROW(sample_local(p.view, n, mean, s, 5, 0), Error);
}

}  // namespace
}  // namespace tsdf_mcl
