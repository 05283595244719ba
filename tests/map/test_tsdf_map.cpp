#include <gtest/gtest.h>

#include <random>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::TsdfMap;

TEST(TsdfMap, BlockAndLocalIndexAtBorders) {
  EXPECT_EQ(TsdfMap::block_of({0, 0, 0}), Vector3i(0, 0, 0));
  EXPECT_EQ(TsdfMap::block_of({7, 7, 7}), Vector3i(0, 0, 0));
  EXPECT_EQ(TsdfMap::block_of({8, 8, 8}), Vector3i(1, 1, 1));
  EXPECT_EQ(TsdfMap::block_of({-1, -8, -9}), Vector3i(-1, -1, -2));
  EXPECT_EQ(TsdfMap::local_index({-1, 0, 0}), 7);
  EXPECT_EQ(TsdfMap::local_index({0, -1, 0}), 7 * 8);
  EXPECT_EQ(TsdfMap::local_index({0, 0, -1}), 7 * 64);
  EXPECT_EQ(TsdfMap::local_index({-8, -8, -8}), 0);
}

// Every voxel of a region spanning several block borders (negative coordinates included) keeps its own value:
// no voxel lands in a neighbour's cell, whatever the float rounding of its centre.
TEST(TsdfMap, EveryVoxelRoundTripsAcrossBlockBorders) {
  const float vs = 0.064f;
  TsdfMap map = TsdfMap::covering(vs, 0.6f, Vector3f(-2, -2, -2), Vector3f(2, 2, 2));
  auto value = [](const Vector3i& v) {
    return 0.001f * static_cast<float>((v.x() * 7 + v.y() * 13 + v.z() * 31) % 500);
  };
  for (int z = -20; z < 20; ++z)
    for (int y = -20; y < 20; ++y)
      for (int x = -20; x < 20; ++x) map.set_distance({x, y, z}, value({x, y, z}));
  const float step = map.quantization_step();
  for (int z = -20; z < 20; ++z)
    for (int y = -20; y < 20; ++y)
      for (int x = -20; x < 20; ++x) {
        const Vector3i v(x, y, z);
        ASSERT_NEAR(*map.distance(v), value(v), step) << x << " " << y << " " << z;
        ASSERT_EQ(map.voxel_of(map.center_of(v)), v);
        // Points anywhere inside the voxel's cube (short of its faces) map back to it.
        const Vector3f jitter(0.49f * vs, -0.49f * vs, 0.3f * vs);
        ASSERT_EQ(map.voxel_of(map.center_of(v) + jitter), v);
        const TsdfMap::Sample s = map.nearest(map.center_of(v) + jitter);
        ASSERT_TRUE(s.known);
        ASSERT_NEAR(s.distance, value(v), step);
      }
  EXPECT_EQ(map.block_count(), 6u * 6u * 6u);  // -20..19 spans blocks -3..2 on each axis
}

TEST(TsdfMap, UnknownOutsideAndFreeBlocks) {
  TsdfMap map = TsdfMap::covering(0.05f, 0.3f, Vector3f(0, 0, 0), Vector3f(1, 1, 1));
  EXPECT_FALSE(map.nearest(Vector3f(0.5f, 0.5f, 0.5f)).known);
  EXPECT_FALSE(map.nearest(Vector3f(50, 0, 0)).known);
  EXPECT_FALSE(map.trilinear(Vector3f(-50, 0, 0)).known);
  map.mark_block_free({0, 0, 0});
  const auto s = map.nearest(Vector3f(0.1f, 0.1f, 0.1f));
  ASSERT_TRUE(s.known);
  EXPECT_FLOAT_EQ(s.distance, 0.3f);
  // Writing into a free block keeps its other voxels free.
  map.set_distance({1, 1, 1}, -0.1f);
  EXPECT_NEAR(*map.distance({1, 1, 1}), -0.1f, map.quantization_step());
  EXPECT_FLOAT_EQ(*map.distance({2, 2, 2}), 0.3f);
  EXPECT_THROW(map.set_distance({1000, 0, 0}, 0.0f), tsdf_mcl::Error);
}

TEST(TsdfMap, TrilinearInterpolatesAndRenormalizesOverKnownCorners) {
  TsdfMap map = TsdfMap::covering(0.1f, 1.0f, Vector3f(-1, -1, -1), Vector3f(1, 1, 1));
  for (int z = -5; z <= 5; ++z)
    for (int y = -5; y <= 5; ++y)
      for (int x = -5; x <= 5; ++x) map.set_distance({x, y, z}, 0.1f * static_cast<float>(x));  // d = world x
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.4f, 0.4f);
  for (int i = 0; i < 200; ++i) {
    const Vector3f p(u(rng), u(rng), u(rng));
    const auto s = map.trilinear(p);
    ASSERT_TRUE(s.known);
    EXPECT_NEAR(s.distance, p.x(), 1e-4);
  }
  map.set_unknown({1, 0, 0});
  const auto s = map.trilinear(Vector3f(0.05f, 0.0f, 0.0f));
  ASSERT_TRUE(s.known);
  EXPECT_NEAR(s.distance, 0.0f, 1e-4);  // only the x=0 corners are known at y=z=0
}

TEST(TsdfMap, CompactTurnsUniformBlocksIntoSentinels) {
  TsdfMap map = TsdfMap::covering(0.05f, 0.3f, Vector3f(0, 0, 0), Vector3f(2, 2, 2));
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) map.set_distance({x, y, z}, 5.0f);  // clamped to +truncation
  map.set_distance({8, 0, 0}, 0.05f);
  map.set_distance({16, 0, 0}, 0.05f);
  map.set_unknown({16, 0, 0});
  EXPECT_EQ(map.block_count(), 3u);
  map.compact();
  EXPECT_EQ(map.block_count(), 1u);
  EXPECT_EQ(map.block_entry({0, 0, 0}), TsdfMap::kFreeBlock);
  EXPECT_EQ(map.block_entry({2, 0, 0}), TsdfMap::kUnknownBlock);
  EXPECT_NEAR(*map.distance({8, 0, 0}), 0.05f, map.quantization_step());
  const auto st = map.stats();
  EXPECT_EQ(st.free_blocks, 1u);
  EXPECT_EQ(st.allocated_blocks, 1u);
}
