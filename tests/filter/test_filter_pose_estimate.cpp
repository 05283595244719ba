#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "owned_particles.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {
namespace {

using test::OwnedParticles;

double angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) { return a.angularDistance(b); }

TEST(RotationAveraging, SymmetricPerturbationsAverageToTheCentreWhateverTheSigns) {
  Rng rng(4);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Quaterniond centre = Eigen::Quaterniond::UnitRandom();
    std::vector<Eigen::Quaterniond> q;
    std::vector<double> w;
    for (int k = 0; k < 30; ++k) {
      const Eigen::Vector3d v(0.3 * rng.normal(), 0.3 * rng.normal(), 0.3 * rng.normal());
      const double weight = 0.5 + rng.uniform();
      for (double s : {1.0, -1.0}) {
        Eigen::Quaterniond p = centre * quaternion_exp((s * v).cast<float>()).cast<double>();
        if (rng.uniform() < 0.5) p.coeffs() = -p.coeffs();  // q and -q are the same rotation
        q.push_back(p);
        w.push_back(weight);
      }
    }
    EXPECT_LT(angle(average_rotation(q, w), centre), 1e-6) << "trial " << trial;
  }
}

TEST(RotationAveraging, WeightsPullTowardsTheHeavierRotation) {
  const Eigen::Quaterniond a = Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond b(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond m = average_rotation({a, b}, {0.75, 0.25});
  // Same axis: the mean turns about it, a quarter of the way for weights 3:1 (to second order).
  EXPECT_NEAR(angle(m, a), 0.05, 1e-3);
  EXPECT_NEAR(angle(m, b), 0.15, 1e-3);
  // Opposite hemispheres of the quaternion sphere average the same way.
  Eigen::Quaterniond b_flipped = b;
  b_flipped.coeffs() = -b.coeffs();
  EXPECT_LT(angle(average_rotation({a, b_flipped}, {0.75, 0.25}), m), 1e-9);
  EXPECT_THROW(average_rotation({}, {}), Error);
  EXPECT_THROW(average_rotation({a}, {0.0}), Error);
}

// Two clouds: the estimate is the mean of the heavier one, not the mean of both.
TEST(PoseEstimator, PicksTheDominantModeNotTheMeanOfTheCloud) {
  Rng rng(9);
  OwnedParticles p(1000);
  std::vector<double> w(1000);
  const Eigen::Vector3f a(1.0f, 1.0f, 1.0f), b(5.0f, 4.0f, 1.0f);
  const Eigen::Quaternionf qa = Eigen::Quaternionf::Identity();
  const Eigen::Quaternionf qb(Eigen::AngleAxisf(1.5f, Eigen::Vector3f::UnitZ()));
  for (std::size_t i = 0; i < 1000; ++i) {
    const bool in_a = i < 600;
    const Eigen::Vector3f n(static_cast<float>(0.05 * rng.normal()), static_cast<float>(0.05 * rng.normal()),
                            static_cast<float>(0.02 * rng.normal()));
    p.view.set(i, (in_a ? a : b) + n,
               (in_a ? qa : qb) * quaternion_exp(Eigen::Vector3f(0, 0, static_cast<float>(0.02 * rng.normal()))));
    w[i] = 1.0;
  }
  PoseEstimator estimator{PoseEstimateOptions{}};
  PoseEstimate e = estimator.estimate(p.view, w.data(), 1000);
  EXPECT_LT((e.pose.translation() - a.cast<double>()).norm(), 0.02);
  EXPECT_LT(angle(Eigen::Quaterniond(e.pose.linear()), qa.cast<double>()), 0.01);
  EXPECT_EQ(e.place_count, 2u);
  EXPECT_EQ(e.place_particles, 600u);
  EXPECT_NEAR(e.place_weight, 0.6, 1e-9);
  EXPECT_FALSE(e.converged);  // 60 % of the weight is not enough

  // Heavier weights on the smaller cloud move the estimate there.
  for (std::size_t i = 600; i < 1000; ++i) w[i] = 2.0;
  e = estimator.estimate(p.view, w.data(), 1000);
  EXPECT_LT((e.pose.translation() - b.cast<double>()).norm(), 0.02);
  EXPECT_LT(angle(Eigen::Quaterniond(e.pose.linear()), qb.cast<double>()), 0.01);
  EXPECT_NEAR(e.place_weight, 800.0 / 1400.0, 1e-9);
}

TEST(PoseEstimator, CovarianceOfAGaussianCloudAndConvergence) {
  Rng rng(2);
  const std::size_t n = 20000;
  OwnedParticles p(n);
  std::vector<double> w(n, 1.0);
  const Eigen::Vector3d sigma_p(0.1, 0.05, 0.02), sigma_r(0.01, 0.01, 0.03);
  const Eigen::Quaternionf mean(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.2f, 0.3f, 1.0f).normalized()));
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d dp(sigma_p.x() * rng.normal(), sigma_p.y() * rng.normal(), sigma_p.z() * rng.normal());
    const Eigen::Vector3d dr(sigma_r.x() * rng.normal(), sigma_r.y() * rng.normal(), sigma_r.z() * rng.normal());
    p.view.set(i, Eigen::Vector3f(2.0f, 3.0f, 1.0f) + dp.cast<float>(), mean * quaternion_exp(dr.cast<float>()));
  }
  PoseEstimator estimator{PoseEstimateOptions{}};
  const PoseEstimate e = estimator.estimate(p.view, w.data(), n);
  EXPECT_EQ(e.place_count, 1u);
  EXPECT_LT((e.pose.translation() - Eigen::Vector3d(2, 3, 1)).norm(), 0.005);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(std::sqrt(e.covariance(a, a)), sigma_p[a], 0.05 * sigma_p[a]) << "position axis " << a;
    EXPECT_NEAR(std::sqrt(e.covariance(3 + a, 3 + a)), sigma_r[a], 0.05 * sigma_r[a]) << "rotation axis " << a;
  }
  EXPECT_NEAR(e.covariance(0, 1), 0.0, 2e-4);
  EXPECT_NEAR(e.std_position, 0.1, 0.005);
  EXPECT_NEAR(e.std_rotation, 0.03, 0.002);
  EXPECT_TRUE(e.converged);

  PoseEstimateOptions strict;
  strict.converged_std_xyz = 0.05;
  PoseEstimator strict_estimator(strict);
  EXPECT_FALSE(strict_estimator.estimate(p.view, w.data(), n).converged);
}

// Two look-alike places 18 m apart: the estimate stays on the one that continues it until the other holds
// switch_ratio times its share, and a place that continues nothing never keeps it.
TEST(EstimatePlace, ATieBetweenLookAlikesDoesNotMoveTheEstimate) {
  const auto place = [](double x, double yaw, double weight) {
    Place h;
    h.pose = pose_from_xyz_rpy(x, 4.0, 1.0, 0.0, 0.0, yaw);
    h.weight = weight;
    return h;
  };
  const Pose prediction = pose_from_xyz_rpy(3.1, 4.0, 1.0, 0.0, 0.0, 0.02);  // where the odometry carries it
  const double ratio = 1.2, jump = 0.5, turn = 0.35;
  // The mirror place (x 21, turned half round) just took the lead: the estimate stays.
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.505), place(3.0, 0.0, 0.495)}, prediction, ratio, jump, turn), 1u);
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.54), place(3.0, 0.0, 0.46)}, prediction, ratio, jump, turn), 1u);
  // Past the ratio it moves; with a ratio of 1 at once.
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.56), place(3.0, 0.0, 0.44)}, prediction, ratio, jump, turn), 0u);
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.505), place(3.0, 0.0, 0.495)}, prediction, 1.0, jump, turn), 0u);
  // The heaviest place continues the estimate: it is the estimate.
  EXPECT_EQ(estimate_place({place(3.0, 0.0, 0.6), place(21.0, M_PI, 0.4)}, prediction, ratio, jump, turn), 0u);
  // No place continues it (the same place turned by 40°, or 0.8 m off): the heaviest.
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.505), place(3.0, 0.7, 0.495)}, prediction, ratio, jump, turn), 0u);
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.505), place(3.9, 0.0, 0.495)}, prediction, ratio, jump, turn), 0u);
  // The heaviest place that continues it counts, not the first in the list.
  EXPECT_EQ(estimate_place({place(21.0, M_PI, 0.45), place(3.0, 0.0, 0.4), place(3.2, 0.0, 0.15)}, prediction, ratio,
                           jump, turn),
            1u);
  EXPECT_EQ(estimate_place({}, prediction, ratio, jump, turn), 0u);
}

TEST(PoseEstimator, YawWrapsAroundAndBestParticleOption) {
  OwnedParticles p(200);
  std::vector<double> w(200, 1.0);
  for (std::size_t i = 0; i < 200; ++i) {
    const float yaw = 3.14159f + 0.002f * (static_cast<float>(i) - 100.0f);  // straddles +-pi
    p.view.set(i, Eigen::Vector3f(0.1f, 0.1f, 0.1f),
               Eigen::Quaternionf(Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ())));
  }
  w[37] = 5.0;
  PoseEstimator estimator{PoseEstimateOptions{}};
  const PoseEstimate e = estimator.estimate(p.view, w.data(), 200);
  EXPECT_EQ(e.place_count, 1u);
  EXPECT_LT(
      angle(Eigen::Quaterniond(e.pose.linear()), Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()))),
      0.01);

  PoseEstimateOptions best;
  best.best_particle = true;
  PoseEstimator best_estimator(best);
  const PoseEstimate b = best_estimator.estimate(p.view, w.data(), 200);
  EXPECT_LT(angle(Eigen::Quaterniond(b.pose.linear()), p.view.rotation(37).cast<double>()), 1e-6);

  std::fill(w.begin(), w.end(), 0.0);
  EXPECT_THROW(estimator.estimate(p.view, w.data(), 200), Error);
}

}  // namespace
}  // namespace tsdf_mcl
