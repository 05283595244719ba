#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <vector>

#include "owned_particles.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {
namespace {

using test::OwnedParticles;

double stddev(const std::vector<double>& v) {
  double m = 0.0, m2 = 0.0;
  for (double x : v) m += x;
  m /= static_cast<double>(v.size());
  for (double x : v) m2 += (x - m) * (x - m);
  return std::sqrt(m2 / static_cast<double>(v.size() - 1));
}

TEST(MotionModel, WithoutNoiseParticlesComposeWithTheMotion) {
  OwnedParticles p(50);
  Rng rng(1);
  std::vector<Pose> before;
  for (std::size_t i = 0; i < 50; ++i) {
    const Pose pose = pose_from_xyz_rpy(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(0, 2), 0.1 * rng.normal(),
                                        0.1 * rng.normal(), rng.uniform(-3, 3));
    p.view.set(i, pose.translation().cast<float>(), Eigen::Quaterniond(pose.linear()).cast<float>());
    before.push_back(pose);
  }
  const Pose delta = pose_from_xyz_rpy(0.7, -0.2, 0.05, 0.02, -0.03, 0.4);
  apply_motion(p.view, 50, delta, MotionNoise{}, 5, 0);
  for (std::size_t i = 0; i < 50; ++i) {
    const Pose expected = before[i] * delta;
    EXPECT_LT((p.view.position(i).cast<double>() - expected.translation()).norm(), 1e-5);
    EXPECT_LT(p.view.rotation(i).cast<double>().angularDistance(Eigen::Quaterniond(expected.linear())), 1e-5);
  }
}

// The sample spread of each axis matches the alpha model for a 1 m, 0.3 rad motion.
TEST(MotionModel, NoiseGrowsWithTheMotionAsSpecifiedPerAxis) {
  MotionParameters mp;
  mp.alpha1 = 0.1;
  mp.alpha2 = 0.05;
  mp.alpha3 = 0.08;
  mp.alpha4 = 0.04;
  mp.alpha5 = 0.03;
  mp.alpha6 = 0.02;
  mp.alpha7 = 0.06;
  mp.alpha8 = 0.01;
  const double d = 1.0, theta = 0.3;
  const Pose delta = pose_from_xyz_rpy(d, 0.0, 0.0, 0.0, 0.0, theta);
  const MotionNoise noise = motion_noise(mp, delta, 0.5);
  EXPECT_NEAR(noise.sigma_along, 0.08 * d + 0.04 * theta, 1e-6);
  EXPECT_NEAR(noise.sigma_across, 0.03 * d + 0.04 * theta, 1e-6);
  EXPECT_NEAR(noise.sigma_vertical, 0.02 * d + 0.04 * theta, 1e-6);
  EXPECT_NEAR(noise.sigma_yaw, 0.1 * theta + 0.05 * d, 1e-6);
  EXPECT_NEAR(noise.sigma_roll, 0.06 * theta + 0.01 * d, 1e-6);
  EXPECT_NEAR(noise.along.x(), 1.0f, 1e-6);

  const std::size_t n = 40000;
  OwnedParticles p(n);
  apply_motion(p.view, n, delta, noise, 7, 3);
  std::vector<double> x, y, z, rx, ry, rz;
  const Eigen::Quaterniond dq_inv(Eigen::Quaterniond(delta.linear()).conjugate());
  for (std::size_t i = 0; i < n; ++i) {
    x.push_back(p.view.x[i]);
    y.push_back(p.view.y[i]);
    z.push_back(p.view.z[i]);
    const Eigen::Vector3d r = quaternion_log(dq_inv * p.view.rotation(i).cast<double>());
    rx.push_back(r.x());
    ry.push_back(r.y());
    rz.push_back(r.z());
  }
  EXPECT_NEAR(stddev(x), noise.sigma_along, 0.03 * noise.sigma_along);
  EXPECT_NEAR(stddev(y), noise.sigma_across, 0.03 * noise.sigma_across);
  EXPECT_NEAR(stddev(z), noise.sigma_vertical, 0.03 * noise.sigma_vertical);
  EXPECT_NEAR(stddev(rx), noise.sigma_roll, 0.03 * noise.sigma_roll);
  EXPECT_NEAR(stddev(ry), noise.sigma_pitch, 0.03 * noise.sigma_pitch);
  EXPECT_NEAR(stddev(rz), noise.sigma_yaw, 0.03 * noise.sigma_yaw);
}

TEST(MotionModel, ImuRotationAndRandomWalk) {
  MotionParameters mp;
  mp.imu_rotation = true;
  mp.imu_sigma = 0.004;
  const Pose turn = pose_from_xyz_rpy(0.5, 0.0, 0.0, 0.0, 0.0, 1.0);
  MotionNoise n = motion_noise(mp, turn, 0.1);
  EXPECT_FLOAT_EQ(n.sigma_yaw, 0.004f);
  EXPECT_FLOAT_EQ(n.sigma_roll, 0.004f);
  EXPECT_GT(n.sigma_along, 0.0f);  // translation noise keeps its alpha terms

  // No odometry: the diffusion model's noise grows with sqrt(dt) and never vanishes.
  mp = MotionParameters{};
  mp.type = MotionModelType::kDiffusion;
  n = motion_noise(mp, Pose::Identity(), 4.0);
  EXPECT_NEAR(n.sigma_along, 2.0 * mp.diffusion_xy, 1e-6);
  EXPECT_NEAR(n.sigma_vertical, 2.0 * mp.diffusion_z, 1e-6);
  EXPECT_NEAR(n.sigma_yaw, 2.0 * mp.diffusion_yaw, 1e-6);
  EXPECT_NEAR(n.sigma_pitch, 2.0 * mp.diffusion_roll_pitch, 1e-6);
}

TEST(MotionModel, ScaleMotion) {
  const Pose delta = pose_from_xyz_rpy(1.0, 0.5, -0.2, 0.1, 0.0, 0.4);
  const Pose twice = scale_motion(delta, 2.0);
  EXPECT_LT((twice.translation() - 2.0 * delta.translation()).norm(), 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(twice.linear()).angle(), 2.0 * Eigen::AngleAxisd(delta.linear()).angle(), 1e-9);
  EXPECT_TRUE(scale_motion(delta, 0.0).isApprox(Pose::Identity()));
  EXPECT_TRUE(scale_motion(delta, 1.0).isApprox(delta, 1e-12));
}

// Every particle draws from its own stream: the result does not depend on the thread count.
TEST(MotionModel, SameResultForAnyThreadCount) {
  const std::size_t n = 5000;
  OwnedParticles a(n), b(n);
  const Pose delta = pose_from_xyz_rpy(0.3, 0.1, 0.0, 0.0, 0.0, 0.2);
  const MotionNoise noise = motion_noise(MotionParameters{}, delta, 0.5);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  apply_motion(a.view, n, delta, noise, 42, 9);
  omp_set_num_threads(4);
  apply_motion(b.view, n, delta, noise, 42, 9);
  omp_set_num_threads(threads);
  EXPECT_EQ(a.data, b.data);
  OwnedParticles c(n);
  apply_motion(c.view, n, delta, noise, 43, 9);
  EXPECT_NE(a.data, c.data);
}

TEST(MotionModel, RejectsBadParameters) {
  EXPECT_THROW(parse_motion_model("teleport"), Error);
  EXPECT_EQ(parse_motion_model("constant_velocity"), MotionModelType::kConstantVelocity);
  MotionParameters mp;
  mp.alpha6 = -0.1;
  EXPECT_THROW(mp.validate(), Error);
  mp = MotionParameters{};
  mp.diffusion_xy = std::nan("");
  EXPECT_THROW(mp.validate(), Error);
}

}  // namespace
}  // namespace tsdf_mcl
