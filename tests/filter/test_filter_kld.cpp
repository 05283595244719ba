#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "owned_particles.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/kld_sampling.hpp"
#include "tsdf_mcl/filter/recovery.hpp"

namespace tsdf_mcl {
namespace {

using test::OwnedParticles;

TEST(KldSampling, SampleCountFormula) {
  // (k-1)/(2 eps) * (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)^3, evaluated by hand.
  EXPECT_NEAR(kld_sample_count(2, 0.05, 0.99), 19.27, 0.02);
  EXPECT_NEAR(kld_sample_count(100, 0.05, 0.99), 1128.7, 0.5);
  EXPECT_NEAR(kld_sample_count(100, 0.05, 2.33), 1347.2, 0.5);
  EXPECT_DOUBLE_EQ(kld_sample_count(1, 0.05, 0.99), 1.0);
  // More bins, a tighter error bound or a higher quantile all need more particles.
  EXPECT_LT(kld_sample_count(50, 0.05, 0.99), kld_sample_count(51, 0.05, 0.99));
  EXPECT_LT(kld_sample_count(50, 0.05, 0.99), kld_sample_count(50, 0.02, 0.99));
  EXPECT_LT(kld_sample_count(50, 0.05, 0.99), kld_sample_count(50, 0.05, 2.33));
}

TEST(KldSampling, OneBinNeedsOnlyTheMinimum) {
  KldParameters p;
  p.min_particles = 123;
  KldSampler kld(p);
  OwnedParticles particles(5000);
  const std::vector<double> w(5000, 1.0);
  EXPECT_EQ(kld.required_count(particles.view, w.data(), 5000), 123u);
  EXPECT_EQ(kld.occupied_bins(), 1u);
}

// 200 equally weighted bins: resampling any N >= 200 populates all of them, so the count is n(200).
TEST(KldSampling, SpreadBeliefNeedsTheBoundForItsBins) {
  KldParameters p;
  p.min_particles = 10;
  p.max_particles = 100000;
  KldSampler kld(p);
  OwnedParticles particles(4000);
  for (std::size_t i = 0; i < 4000; ++i) particles.view.x[i] = 0.5f * static_cast<float>(i % 200) + 0.1f;
  std::vector<double> w(4000, 1.0);
  const std::size_t n = kld.required_count(particles.view, w.data(), 4000);
  EXPECT_EQ(kld.occupied_bins(), 200u);
  EXPECT_EQ(n, static_cast<std::size_t>(std::ceil(kld_sample_count(200, p.pf_err, p.pf_z))));

  // Bins that carry almost no weight hardly count: resampling would not populate them.
  for (std::size_t i = 0; i < 4000; ++i) w[i] = (i % 200) < 20 ? 1.0 : 1e-9;
  const std::size_t concentrated = kld.required_count(particles.view, w.data(), 4000);
  EXPECT_LT(concentrated, static_cast<std::size_t>(kld_sample_count(25, p.pf_err, p.pf_z)));
  EXPECT_GE(concentrated, static_cast<std::size_t>(kld_sample_count(20, p.pf_err, p.pf_z)));

  // Rotations count too: the same positions in 10° yaw steps are distinct bins.
  for (std::size_t i = 0; i < 4000; ++i) {
    particles.view.x[i] = 0.1f;
    const float yaw = 0.1745329f * static_cast<float>(i % 36) + 0.05f - 3.14159f;
    particles.view.qw[i] = std::cos(0.5f * yaw);
    particles.view.qz[i] = std::sin(0.5f * yaw);
  }
  std::fill(w.begin(), w.end(), 1.0);
  kld.required_count(particles.view, w.data(), 4000);
  EXPECT_EQ(kld.occupied_bins(), 36u);
}

TEST(KldSampling, ClampsToMaxParticles) {
  KldParameters p;
  p.min_particles = 10;
  p.max_particles = 300;
  KldSampler kld(p);
  OwnedParticles particles(2000);
  for (std::size_t i = 0; i < 2000; ++i) particles.view.y[i] = 0.3f * static_cast<float>(i);
  const std::vector<double> w(2000, 1.0);
  EXPECT_EQ(kld.required_count(particles.view, w.data(), 2000), 300u);
}

TEST(KldSampling, RejectsBadParameters) {
  KldParameters p;
  p.max_particles = 10;
  p.min_particles = 20;
  EXPECT_THROW(p.validate(), Error);
  p = KldParameters{};
  p.pf_err = 0.0;
  EXPECT_THROW(p.validate(), Error);
  p = KldParameters{};
  p.bin_angle = -1.0f;
  EXPECT_THROW(KldSampler{p}, Error);
}

TEST(Recovery, InjectsOnlyWhenTheFitDropsBeyondTheMargin) {
  RecoveryMonitor off(0.0, 0.1);
  EXPECT_FALSE(off.enabled());
  EXPECT_EQ(off.update(1.0), 0.0);
  EXPECT_EQ(off.update(0.001), 0.0);

  RecoveryMonitor r(0.05, 0.3, 0.3);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(r.update(1.0), 0.0);
  // A 20 % dip stays within the margin.
  for (int i = 0; i < 10; ++i) EXPECT_EQ(r.update(0.8), 0.0);
  for (int i = 0; i < 50; ++i) r.update(1.0);
  // A lost track: the share grows as w_fast falls.
  double previous = 0.0;
  for (int i = 0; i < 6; ++i) {
    const double share = r.update(0.02);
    EXPECT_GE(share, previous);
    previous = share;
  }
  EXPECT_GT(previous, 0.5);
  EXPECT_LE(previous, 1.0);
  // Found again: w_fast climbs back above the bar and injection stops.
  for (int i = 0; i < 10; ++i) r.update(1.0);
  EXPECT_EQ(r.update(1.0), 0.0);

  // Without a margin the same 20 % dip injects.
  RecoveryMonitor textbook(0.05, 0.3, 0.0);
  for (int i = 0; i < 50; ++i) textbook.update(1.0);
  EXPECT_GT(textbook.update(0.8), 0.0);

  EXPECT_THROW(RecoveryMonitor(0.5, 0.1), Error);
  EXPECT_THROW(RecoveryMonitor(0.01, 0.1, 1.0), Error);
}

}  // namespace
}  // namespace tsdf_mcl
