// ParticleFilter's global search: the first scan's hypotheses screened over the map's free space, the best kept and
// climbed (filter_core.hpp).
#include <algorithm>
#include <cmath>

#include "filter_core.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/random.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {

void ParticleFilter::Core::initialize_global() {
  GlobalProposal& g = proposal();
  g.use_uniform();
  g.sample(evaluator_.particles(), 0, params_.initial_particles, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
}

void ParticleFilter::Core::initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras) {
  if (points.empty()) throw Error("global initialization: the scan has no points");
  GlobalProposal& g = proposal();
  if (extras.dense || extras.imu_up)
    g.use_scan(extras.dense ? *extras.dense : points, extras.imu_up);
  else
    g.use_uniform();
  const std::size_t n = params_.initial_particles;
  if (params_.global_search.candidates > n) {
    reserve_search(params_.global_search.candidates);
    search(params_.global_search.candidates, n, points, evaluator_.spare_particles(), 0);
    evaluator_.swap_particles();
    climb(n, points);
  } else {
    g.sample(evaluator_.particles(), 0, n, params_.seed, step_);
  }
  ++step_;
  start(n);
}

EndpointModel ParticleFilter::Core::screening_model() const {
  EndpointModel wide = params_.sensor;
  wide.sigma_hit = std::max(wide.sigma_hit, params_.global_search.screen_sigma);
  wide.weight_exponent = 1.0f;
  wide.unknown_distance = map_.truncation();  // a smooth basin (EndpointModel::unknown_distance)
  return wide;
}

namespace {

// The points a block of hypotheses is scored on, spread over the scan. For a gravity candidate, the rays
// within 20° of its horizon: they hit walls and furniture, which tell positions and headings apart, while
// floor and ceiling points fit any place at the right height (an OS0's +-45° beams are half floor and
// ceiling, and scored on them a million hypotheses ranked the right place with the wrong ones).
std::vector<Eigen::Vector3f> screening_points(const std::vector<Eigen::Vector3f>& points, const GravityCandidate* c,
                                              std::size_t count) {
  std::vector<Eigen::Vector3f> eligible;
  if (c) {
    const float horizon = std::sin(0.35f);
    for (const Eigen::Vector3f& p : points) {
      if (std::abs(p.dot(c->up)) <= horizon * p.norm()) eligible.push_back(p);
    }
  }
  const std::vector<Eigen::Vector3f>& from = eligible.size() >= count / 2 ? eligible : points;
  // The preprocessed points are in space-filling-curve order: every k-th one is spread over the scan.
  std::vector<Eigen::Vector3f> subset;
  const std::size_t every = std::max<std::size_t>(1, from.size() / count);
  for (std::size_t i = 0; i < from.size() && subset.size() < count; i += every) subset.push_back(from[i]);
  return subset;
}

}  // namespace

void ParticleFilter::Core::climb(std::size_t n, const std::vector<Eigen::Vector3f>& points) {
  const GlobalSearchOptions& o = params_.global_search;
  if (o.climb_rounds == 0) return;
  constexpr std::size_t kTries = 3;  // jittered copies per particle and round
  if ((kTries + 1) * n > capacity_) {
    capacity_ = (kTries + 1) * n;
    evaluator_.reserve(capacity_, points_capacity_);
  }
  const EndpointModel wide = screening_model();
  std::vector<Eigen::Vector3f> subset;
  const std::size_t every = std::max<std::size_t>(1, points.size() / (2 * o.screen_points));
  for (std::size_t i = 0; i < points.size() && subset.size() < 2 * o.screen_points; i += every)
    subset.push_back(points[i]);
  if (subset.size() > points_capacity_) {
    points_capacity_ = subset.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  evaluator_.set_points(subset);
  for (std::size_t round = 0; round < o.climb_rounds; ++round) {
    // Smaller steps each round: from about the screening's resolution down.
    const double scale = 1.0 / static_cast<double>(round + 1);
    const auto step_xyz = static_cast<float>(0.1 * scale);
    const auto step_angle = static_cast<float>(0.03 * scale);
    const ParticleArrays p = evaluator_.particles();
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
    for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
      const auto i = static_cast<std::size_t>(k);
      Rng rng(params_.seed, 0xC11B0ull + round, step_, i);
      for (std::size_t t = 0; t < kTries; ++t) {
        const Eigen::Vector3f dp(step_xyz * static_cast<float>(rng.normal()),
                                 step_xyz * static_cast<float>(rng.normal()),
                                 step_xyz * static_cast<float>(rng.normal()));
        const Eigen::Vector3f dr(step_angle * static_cast<float>(rng.normal()),
                                 step_angle * static_cast<float>(rng.normal()),
                                 step_angle * static_cast<float>(rng.normal()));
        p.set(n + kTries * i + t, p.position(i) + dp, (p.rotation(i) * quaternion_exp(dr)).normalized());
      }
    }
    evaluator_.weigh((kTries + 1) * n, wide);
    // Each hypothesis moves to its best variant: a climb per hypothesis, no competition between them, so a
    // look-alike the screening found keeps its place beside the right one.
    const ParticleArrays dst = evaluator_.spare_particles();
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t best = i;
      for (std::size_t t = 0; t < kTries; ++t) {
        const std::size_t c = n + kTries * i + t;
        if (p.log_weight[c] > p.log_weight[best]) best = c;
      }
      dst.set(i, p.position(best), p.rotation(best));
    }
    evaluator_.swap_particles();
  }
}

void ParticleFilter::Core::reserve_search(std::size_t candidates) {
  const GlobalProposal& g = proposal();
  std::size_t largest = 0;
  for (std::size_t b = 0; b < g.blocks(); ++b) {
    largest =
        std::max(largest, static_cast<std::size_t>(std::lround(g.block_share(b) * static_cast<double>(candidates))));
  }
  if (largest > capacity_) {
    capacity_ = largest;
    evaluator_.reserve(capacity_, points_capacity_);
  }
}

void ParticleFilter::Core::search(std::size_t candidates, std::size_t keep, const std::vector<Eigen::Vector3f>& points,
                                  const ParticleArrays& dst, std::size_t offset) {
  const GlobalSearchOptions& o = params_.global_search;
  const GlobalProposal& g = proposal();
  // The kept hypotheses are shared between the blocks by their mixture weights (largest remainders).
  const std::size_t blocks = g.blocks();
  std::vector<std::size_t> keep_of(blocks, 0);
  std::vector<std::pair<double, std::size_t>> remainder;
  std::size_t assigned = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    const double exact = g.block_share(b) * static_cast<double>(keep);
    keep_of[b] = static_cast<std::size_t>(std::floor(exact));
    assigned += keep_of[b];
    remainder.emplace_back(exact - std::floor(exact), b);
  }
  std::sort(remainder.begin(), remainder.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  for (std::size_t r = 0; assigned < keep; ++r, ++assigned) ++keep_of[remainder[r % blocks].second];

  const EndpointModel wide = screening_model();
  const ParticleArrays scratch = evaluator_.particles();
  std::vector<std::uint32_t> order;
  std::size_t written = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    if (keep_of[b] == 0) continue;
    const std::size_t m =
        std::clamp(static_cast<std::size_t>(std::lround(g.block_share(b) * static_cast<double>(candidates))),
                   keep_of[b], capacity_);
    g.sample_block(b, scratch, 0, m, params_.seed, step_);
    const std::vector<Eigen::Vector3f> subset = screening_points(points, g.block_candidate(b), o.screen_points);
    if (subset.size() > points_capacity_) {
      points_capacity_ = subset.size();
      evaluator_.reserve(capacity_, points_capacity_);
    }
    evaluator_.set_points(subset);
    evaluator_.weigh(m, wide);
    order.resize(m);
    for (std::size_t i = 0; i < m; ++i) order[i] = static_cast<std::uint32_t>(i);
    const std::size_t k = keep_of[b];
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k - 1), order.end(),
                     [&](std::uint32_t a, std::uint32_t c) {
                       return scratch.log_weight[a] > scratch.log_weight[c] ||
                              (scratch.log_weight[a] == scratch.log_weight[c] && a < c);
                     });
    std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k));
    for (std::size_t j = 0; j < k; ++j)
      dst.set(offset + written + j, scratch.position(order[j]), scratch.rotation(order[j]));
    written += k;
  }
}

}  // namespace tsdf_mcl
