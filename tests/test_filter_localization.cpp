#include <gtest/gtest.h>

#include <cstdio>

#include "filter_test_scene.hpp"
#include "tsdf_mcl/particle_filter.hpp"
#include "tsdf_mcl/scan_preprocessing.hpp"

namespace tsdf_mcl {
namespace {

struct World {
  std::vector<test::Box> boxes = test::office_boxes();
  TsdfMap map = test::make_office_map();
  std::vector<Pose> truth = test::office_trajectory(120);
  std::vector<Pose> odom = test::drifting_odometry(truth, 5);
  std::vector<std::vector<Eigen::Vector3f>> scans;
  World() {
    Rng rng(3);
    for (const Pose& p : truth) scans.push_back(test::simulate_scan(boxes, p, rng));
  }
};

const World& world() {
  static const World w;
  return w;
}

FilterParameters ground_robot_params() {
  FilterParameters p;
  p.initial_particles = 20000;
  p.kld.max_particles = 20000;
  p.kld.min_particles = 300;
  p.global_init.max_tilt = 0.1;
  p.global_init.use_height_band = true;
  p.global_init.min_height = 0.6;
  p.global_init.max_height = 1.2;
  p.sensor.sigma_hit = 0.1f;
  p.update_min_d = 0.0;
  p.update_min_a = 0.0;
  return p;
}

TEST(FilterExplore, Global) {
  const World& w = world();
  std::string note;
  EvaluatorOptions eo;
  eo.backend = Backend::kCpu;
  auto eval = make_evaluator(w.map, eo, &note);
  FilterParameters params = ground_robot_params();
  ParticleFilter filter(w.map, *eval, params, 256);
  ScanPreprocessing pre;
  pre.max_beams = 256;
  ScanPreprocessor prep(pre);
  filter.initialize_global();
  std::fprintf(stderr, "free voxels %zu\n", filter.free_space_voxels());
  std::vector<std::size_t> seq;
  for (std::size_t i = 0; i < 30; ++i) seq.push_back(i);
  for (std::size_t i = 75; i < 120; ++i) seq.push_back(i);
  Pose odom = w.odom[0];
  for (std::size_t k = 0; k < seq.size(); ++k) {
    const std::size_t i = seq[k];
    if (k > 0) odom = odom * (w.odom[i - 1].inverse() * w.odom[i]);
    const auto& pts = prep.process(w.scans[i], i);
    const FilterStep s = filter.update(0.5 * static_cast<double>(k), pts, odom);
    std::fprintf(stderr, "%2zu n=%6zu->%6zu bins=%5zu ess=%8.1f beta=%.4f fit=%.3f ws=%.3f wf=%.3f inj=%zu err=%.3f m %.2f deg modes=%zu mw=%.2f sp=%.3f sr=%.3f conv=%d  t=%.1f ms (w %.1f)\n",
                 i, s.particles, s.next_particles, s.kld_bins, s.ess, s.tempering, s.fit, s.w_slow, s.w_fast, s.injected,
                 test::translation_error(s.estimate.pose, w.truth[i]), test::rotation_error(s.estimate.pose, w.truth[i]) * 57.3,
                 s.estimate.modes, s.estimate.mode_weight, s.estimate.std_position, s.estimate.std_rotation * 57.3, s.estimate.converged,
                 s.timings.total_ms, s.timings.weight_ms);
  }
}

}  // namespace
}  // namespace tsdf_mcl
