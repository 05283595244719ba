#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/random.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"

namespace tsdf_mcl {
namespace {

// A dense ring of points around the sensor at 8-12 m, closer points on one side (as a LiDAR near a wall).
std::vector<Eigen::Vector3f> ring_scan(std::size_t n, Rng& rng) {
  std::vector<Eigen::Vector3f> pts;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = rng.uniform(-M_PI, M_PI);
    const double r = a > 2.0 ? rng.uniform(2.0, 3.0) : rng.uniform(8.0, 12.0);
    pts.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)),
                     static_cast<float>(rng.uniform(-1, 2)));
  }
  return pts;
}

TEST(ScanPreprocessing, RangeLimits) {
  ScanPreprocessing o;
  o.laser_min_range = 1.0f;
  o.laser_max_range = 60.0f;
  o.voxel_size = 0.0f;
  ScanPreprocessor pre(o);
  const std::vector<Eigen::Vector3f> pts = {{0.5f, 0, 0}, {0, 1.5f, 0}, {70, 0, 0}, {0, 0, -59.0f}, {0.6f, 0.6f, 0.6f}};
  PreprocessingStats stats;
  const auto& out = pre.process(pts, 0, &stats);
  ASSERT_EQ(out.size(), 3u);
  for (const auto& p : out) {
    EXPECT_GE(p.norm(), 1.0f);
    EXPECT_LE(p.norm(), 60.0f);
  }
  EXPECT_EQ(stats.input, 5u);
  EXPECT_EQ(stats.in_range, 3u);
}

TEST(ScanPreprocessing, VoxelThinningKeepsOnePointPerVoxel) {
  ScanPreprocessing o;
  o.voxel_size = 0.5f;
  o.max_beams = 1000;
  ScanPreprocessor pre(o);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 100; ++i) pts.emplace_back(5.1f + 0.003f * static_cast<float>(i), 2.1f, 0.2f);  // one voxel
  pts.emplace_back(-5.2f, 2.1f, 0.2f);
  PreprocessingStats stats;
  const auto& out = pre.process(pts, 0, &stats);
  EXPECT_EQ(stats.thinned, 2u);
  ASSERT_EQ(out.size(), 2u);
}

// The cap takes exactly max_beams points, spread over the whole scan (every azimuth sector gets its share
// of the thinned points), the same ones for the same seed and scan, other ones for another scan.
TEST(ScanPreprocessing, CapIsSpreadAndDeterministic) {
  Rng rng(8);
  const auto pts = ring_scan(30000, rng);
  ScanPreprocessing o;
  o.max_beams = 256;
  o.voxel_size = 0.2f;
  ScanPreprocessor pre(o);
  PreprocessingStats stats;
  const std::vector<Eigen::Vector3f> a = pre.process(pts, 4, &stats);
  ASSERT_EQ(a.size(), 256u);
  EXPECT_GT(stats.thinned, 1000u);
  const std::vector<Eigen::Vector3f> b = pre.process(pts, 4);
  EXPECT_EQ(a, b);
  const std::vector<Eigen::Vector3f> c = pre.process(pts, 5);
  EXPECT_NE(a, c);
  ScanPreprocessor other_seed([&] {
    ScanPreprocessing s = o;
    s.seed = 1;
    return s;
  }());
  EXPECT_NE(a, other_seed.process(pts, 4));

  // Azimuth sectors of the far ring: each of the 8 gets about an eighth of the far points.
  const auto& thinned_all = [&] {
    ScanPreprocessing s = o;
    s.max_beams = 1000000;
    return ScanPreprocessor(s).process(pts, 4);
  }();
  std::vector<double> share_all(8, 0.0), share_cap(8, 0.0);
  auto sector = [](const Eigen::Vector3f& p) {
    return static_cast<int>(std::floor((std::atan2(p.y(), p.x()) + M_PI) / (M_PI / 4))) & 7;
  };
  for (const auto& p : thinned_all)
    share_all[static_cast<std::size_t>(sector(p))] += 1.0 / static_cast<double>(thinned_all.size());
  for (const auto& p : a) share_cap[static_cast<std::size_t>(sector(p))] += 1.0 / 256.0;
  for (int s = 0; s < 8; ++s)
    EXPECT_NEAR(share_cap[static_cast<std::size_t>(s)], share_all[static_cast<std::size_t>(s)], 0.05) << "sector " << s;
}

TEST(ScanPreprocessing, RejectsBadInput) {
  ScanPreprocessor pre{ScanPreprocessing{}};
  std::vector<Eigen::Vector3f> pts = {{3, 0, 0}, {std::nanf(""), 0, 0}};
  EXPECT_THROW(pre.process(pts, 0), Error);
  ScanPreprocessing o;
  o.max_beams = 0;
  EXPECT_THROW(ScanPreprocessor{o}, Error);
  o = ScanPreprocessing{};
  o.laser_min_range = 10.0f;
  o.laser_max_range = 5.0f;
  EXPECT_THROW(o.validate(), Error);
  // Nothing in range: an empty result, which the caller reports.
  EXPECT_TRUE(pre.process({{0.1f, 0, 0}}, 0).empty());
}

}  // namespace
}  // namespace tsdf_mcl
