#include "place_refinement.hpp"

#include <algorithm>
#include <limits>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"

namespace tsdf_mcl {
namespace {

// Whether each point, seen from `pose`, ends in a voxel the map observed.
void known_endpoints(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points,
                     std::vector<std::uint8_t>& known) {
  const kernel::MapView view(map);
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  known.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f g = (r * points[i] + t) * view.inv_voxel;
    const float at[3] = {g.x(), g.y(), g.z()};
    known[i] = kernel::sample_nearest(view, at) != TsdfMap::kUnknownValue ? 1 : 0;
  }
}

struct Start {
  std::size_t place;
  Pose pose;
  double total;
  std::vector<double> log;
  WallTilt walls;
  std::vector<std::uint8_t> known;  // the point ends in a voxel the map observed
};

Pose particle_pose(const ParticleArrays& particles, std::size_t i) {
  Pose start = Pose::Identity();
  start.linear() = particles.rotation(i).cast<double>().normalized().toRotationMatrix();
  start.translation() = particles.position(i).cast<double>();
  return start;
}

}  // namespace

std::vector<std::vector<std::size_t>> heaviest_particles(const std::int32_t* group, const double* w, std::size_t n,
                                                         std::size_t groups, std::size_t k) {
  const auto heavier = [&](std::size_t a, std::size_t b) { return w[a] > w[b] || (w[a] == w[b] && a < b); };
  std::vector<std::vector<std::size_t>> best(groups);
  for (std::size_t i = 0; i < n; ++i) {
    const auto g = static_cast<std::size_t>(group[i]);
    if (g >= groups || k == 0) continue;
    std::vector<std::size_t>& b = best[g];
    if (b.size() == k && !heavier(i, b.back())) continue;
    b.insert(std::upper_bound(b.begin(), b.end(), i, heavier), i);
    if (b.size() > k) b.pop_back();
  }
  return best;
}

RefinedPlaces refine_places(const TsdfMap& map, const std::vector<Place>& h, const ParticleArrays& particles,
                            const std::vector<std::vector<std::size_t>>& particle_starts,
                            const std::vector<Eigen::Vector3f>& points, const EndpointModel& plain,
                            float inlier_distance, float frontier_reach, double dead_band,
                            const std::function<WallTilt(const Pose&)>& walls_at) {
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  std::vector<Start> starts;
  for (std::size_t r = 0; r < h.size(); ++r) {
    starts.push_back(Start{r, h[r].pose, kNone, {}, walls_at(h[r].pose), {}});
    for (const std::size_t i : particle_starts[r]) {
      const Pose start = particle_pose(particles, i);
      starts.push_back(Start{r, start, kNone, {}, walls_at(start), {}});
    }
  }
  // The refinements are independent (the map is read-only): one per thread and start.
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t ss = 0; ss < static_cast<std::ptrdiff_t>(starts.size()); ++ss) {
    Start& s = starts[static_cast<std::size_t>(ss)];
    s.pose = refine_pose(map, s.pose, points, 6, &s.walls);
    const Eigen::Quaternionf q(Eigen::Quaterniond(s.pose.linear()).cast<float>());
    point_log_likelihoods(map, plain, s.pose.translation().cast<float>(), q, points, s.log);
    s.total = 0.0;
    for (double l : s.log) s.total += l;
    if (particle_starts[s.place].empty()) continue;  // the only start of its place: nothing to compare
    known_endpoints(map, s.pose, points, s.known);
  }
  RefinedPlaces places;
  places.pose.resize(h.size());
  places.total.assign(h.size(), kNone);
  places.point_log.resize(h.size());
  places.observed.resize(h.size());
  places.fit.resize(h.size());
  std::vector<std::size_t> chosen(h.size(), starts.size());
  for (std::size_t k = 0; k < starts.size(); ++k) {
    std::size_t& c = chosen[starts[k].place];
    if (c == starts.size()) {
      c = k;
      continue;
    }
    const PairedEvidence e = paired_evidence(starts[k].log, starts[k].known, starts[c].log, starts[c].known, dead_band);
    if (e.sum > 0.0) c = k;
  }
  for (std::size_t r = 0; r < h.size(); ++r) {
    Start& s = starts[chosen[r]];
    places.total[r] = s.total;
    places.pose[r] = s.pose;
    places.point_log[r].swap(s.log);
  }
  // One place at a time, each fit's rays on every thread (ray_fit): a track has one or two places.
  for (std::size_t r = 0; r < h.size(); ++r) {
    places.fit[r] = ray_fit(map, places.pose[r], points, inlier_distance, kSeeThroughMargin, &places.observed[r]);
    if (frontier_reach > 0.0f) drop_frontier_points(map, places.pose[r], points, frontier_reach, places.observed[r]);
  }
  for (std::size_t r = 0; r < h.size(); ++r) {
    if (places.total[r] > places.total[places.reference]) places.reference = r;
  }
  return places;
}

}  // namespace tsdf_mcl
