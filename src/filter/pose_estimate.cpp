#include "tsdf_mcl/filter/pose_estimate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kTwoPi = 6.283185307179586;
constexpr std::uint32_t kNoCell = 0xFFFFFFFFu;
constexpr std::size_t kDescribeChunk = 4096;  // particles a partial sum: fixed, so sums do not depend on threads

std::uint64_t cell_key(const PoseEstimator::Cell& c) {
  std::uint64_t key = 0x51ED27A4u;
  for (int a = 0; a < 5; ++a) key = hash_combine(key, static_cast<std::uint64_t>(static_cast<std::int64_t>(c[a])));
  return key | 1u;
}

Eigen::Quaterniond markley_mean(const Eigen::Matrix4d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> solver(m);
  const Eigen::Vector4d v = solver.eigenvectors().col(3);  // eigenvalues ascend: the last is the largest
  return Eigen::Quaterniond(v[0], v[1], v[2], v[3]).normalized();
}

}  // namespace

void PoseEstimateOptions::validate() const {
  if (!(cluster_bin_xyz > 0.0f)) throw Error("cluster_bin_xyz must be positive");
  if (!(cluster_bin_yaw > 0.0f && cluster_bin_yaw <= 6.2832f)) throw Error("cluster_bin_yaw must lie in (0, 2 pi]");
  if (!(converged_weight >= 0.0 && converged_weight <= 1.0)) throw Error("converged_weight must lie in [0, 1]");
  if (!(converged_std_xyz > 0.0)) throw Error("converged_std_xyz must be positive");
  if (!(converged_std_angle > 0.0)) throw Error("converged_std_angle must be positive");
  if (max_places == 0) throw Error("max_places must be at least 1");
  if (!(min_relative_weight >= 0.0 && min_relative_weight < 1.0))
    throw Error("pose estimate: min_relative_weight must lie in [0, 1)");
}

Eigen::Quaterniond average_rotation(const std::vector<Eigen::Quaterniond>& rotations,
                                    const std::vector<double>& weights) {
  if (rotations.empty() || rotations.size() != weights.size()) {
    throw Error("average_rotation: needs one weight per rotation and at least one rotation");
  }
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  double total = 0.0;
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    const Eigen::Quaterniond q = rotations[i].normalized();
    const Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
    m += weights[i] * v * v.transpose();
    total += weights[i];
  }
  if (!(total > 0.0)) throw Error("average_rotation: the weights sum to zero");
  return markley_mean(m);
}

PoseEstimator::PoseEstimator(const PoseEstimateOptions& options) : options_(options) {
  options_.validate();
  yaw_cells_ = std::max(1, static_cast<int>(std::lround(kTwoPi / options_.cluster_bin_yaw)));
}

std::uint32_t PoseEstimator::find(std::uint32_t a) {
  while (parent_[a] != a) {
    parent_[a] = parent_[parent_[a]];
    a = parent_[a];
  }
  return a;
}

namespace {

// Which signed sensor axis points most nearly up (0..5: +x, -x, +y, -y, +z, -z), and the yaw of a sensor axis
// perpendicular to it: together a rotation's coarse cell for any tilt.
void rotation_cell(const Eigen::Quaternionf& q, int* up_axis, double* yaw) {
  const Eigen::Matrix3f r = q.toRotationMatrix();
  const Eigen::Vector3f up_in_sensor = r.row(2).transpose();  // world z in the sensor frame
  int axis = 0;
  float best = -2.0f;
  for (int a = 0; a < 3; ++a) {
    for (int s = 0; s < 2; ++s) {
      const float v = s == 0 ? up_in_sensor[a] : -up_in_sensor[a];
      if (v > best) {
        best = v;
        axis = 2 * a + s;
      }
    }
  }
  *up_axis = axis;
  // x for an upright or upside-down sensor (the usual case: the yaw of the heading), else y or z.
  const int reference = axis >= 4 ? 0 : (axis >= 2 ? 2 : 1);
  const Eigen::Vector3f ax = r.col(reference);
  *yaw = std::atan2(ax.y(), ax.x());
}

double largest_std(const Eigen::Matrix3d& m) {
  return std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m, Eigen::EigenvaluesOnly).eigenvalues()[2]));
}

}  // namespace

std::int32_t PoseEstimator::place_of(std::size_t i) const {
  if (i >= particle_cell_.size() || particle_cell_[i] == kNoCell) return -1;
  return root_rank_[parent_[particle_cell_[i]]];
}

PoseEstimate PoseEstimator::estimate(const ParticleArrays& p, const double* w, std::size_t n) {
  if (n == 0) throw Error("pose estimate: no particles");
  double w_max = 0.0;
  std::size_t best = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (w[i] > w_max) {
      w_max = w[i];
      best = i;
    }
  }
  if (!(w_max > 0.0) || !std::isfinite(w_max)) throw Error("pose estimate: no particle has a positive weight");
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) total += w[i];

  bin_particles(p, w, n, options_.min_relative_weight * w_max);
  join_neighbour_cells();
  PoseEstimate e;
  const std::size_t k = rank_components(&e.place_count);
  e.places = describe(p, w, n, k, total);
  e.converged = take_dominant_place(e, options_);
  if (options_.best_particle) {
    e.pose.linear() = p.rotation(best).cast<double>().normalized().toRotationMatrix();
    e.pose.translation() = p.position(best).cast<double>();
  }
  return e;
}

std::uint32_t PoseEstimator::cell_of(const Cell& c, std::uint64_t key, bool insert) {
  const std::size_t slots = table_.size();
  std::size_t s = static_cast<std::size_t>(key) & (slots - 1);
  // Equal hashes of different cells (64 bits: never met) would merge them, which costs a little clustering.
  while (table_[s].key != 0 && table_[s].key != key) s = (s + 1) & (slots - 1);
  if (table_[s].key != 0) return table_[s].cell;
  if (!insert) return kNoCell;
  table_[s].key = key;
  table_[s].cell = static_cast<std::uint32_t>(cells_.size());
  cells_.push_back(c);
  cell_weight_.push_back(0.0);
  return table_[s].cell;
}

void PoseEstimator::bin_particles(const ParticleArrays& p, const double* w, std::size_t n, double threshold) {
  // Cells of the (x, y, z, yaw, up axis) grid.
  std::size_t slots = 16;
  while (slots < 2 * n) slots *= 2;
  if (table_.size() < slots) table_.resize(slots);
  std::fill(table_.begin(), table_.end(), Slot{});
  cells_.clear();
  cell_weight_.clear();
  particle_cell_.assign(n, kNoCell);
  // Each particle's cell and its hash (atan2, a rotation matrix and ten mixes a particle: in parallel), then the
  // cells in particle order into the table (sequential: the cells' numbering, and so every tie below, does not
  // depend on the threads).
  particle_cells_.resize(n);
  particle_keys_.resize(n);
  const float inv_xyz = 1.0f / options_.cluster_bin_xyz;
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (!(w[i] > threshold)) continue;
    const Eigen::Vector3f pos = p.position(i);
    int up_axis = 0;
    double yaw = 0.0;
    rotation_cell(p.rotation(i), &up_axis, &yaw);
    int yc = static_cast<int>(std::floor((yaw + kTwoPi / 2) / kTwoPi * yaw_cells_));
    yc = ((yc % yaw_cells_) + yaw_cells_) % yaw_cells_;
    particle_cells_[i] =
        Cell{static_cast<int>(std::floor(pos.x() * inv_xyz)), static_cast<int>(std::floor(pos.y() * inv_xyz)),
             static_cast<int>(std::floor(pos.z() * inv_xyz)), yc, up_axis};
    particle_keys_[i] = cell_key(particle_cells_[i]);
  }
  // A global belief's cells spread over a table of megabytes: each probe a cache miss unless fetched ahead.
  constexpr std::size_t kAhead = 16;
  const std::size_t mask = table_.size() - 1;
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kAhead < n) __builtin_prefetch(&table_[static_cast<std::size_t>(particle_keys_[i + kAhead]) & mask]);
    if (!(w[i] > threshold)) continue;
    const std::uint32_t cell = cell_of(particle_cells_[i], particle_keys_[i], true);
    particle_cell_[i] = cell;
    cell_weight_[cell] += w[i];
  }
}

void PoseEstimator::join_neighbour_cells() {
  // Connected components over face neighbours (one step along x, y, z or yaw; yaw wraps; the up axis never
  // changes within a component). Each cell looks up the positive side only: the negative side is the same
  // pairs seen from the other cell. The 80 diagonal neighbours would join a little more, at ten times the
  // cost, for the 100k cells of a global belief.
  const auto cells = static_cast<std::uint32_t>(cells_.size());
  parent_.resize(cells);
  for (std::uint32_t c = 0; c < cells; ++c) parent_[c] = c;
  // The neighbours' lookups read the table only: in parallel. The unions after them in any order give the same
  // components, each rooted at its lowest cell.
  neighbours_.resize(4 * static_cast<std::size_t>(cells));
#pragma omp parallel for schedule(static) if (cells >= kParallelParticles)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(cells); ++k) {
    const auto c = static_cast<std::size_t>(k);
    // The four probes' cache misses overlap: all four slots are fetched before the first is read.
    Cell nb[4];
    std::uint64_t key[4];
    for (int axis = 0; axis < 4; ++axis) {
      nb[axis] = cells_[c];
      nb[axis][static_cast<std::size_t>(axis)] += 1;
      nb[axis][3] = nb[axis][3] % yaw_cells_;
      key[axis] = cell_key(nb[axis]);
      __builtin_prefetch(&table_[static_cast<std::size_t>(key[axis]) & (table_.size() - 1)]);
    }
    for (int axis = 0; axis < 4; ++axis) {
      neighbours_[4 * c + static_cast<std::size_t>(axis)] = cell_of(nb[axis], key[axis], false);
    }
  }
  for (std::uint32_t c = 0; c < cells; ++c) {
    for (std::size_t axis = 0; axis < 4; ++axis) {
      const std::uint32_t other = neighbours_[4 * static_cast<std::size_t>(c) + axis];
      if (other == kNoCell) continue;
      const std::uint32_t ra = find(c);
      const std::uint32_t rb = find(other);
      if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
}

std::size_t PoseEstimator::rank_components(std::size_t* modes) {
  const auto cells = static_cast<std::uint32_t>(cells_.size());
  root_weight_.assign(cells, 0.0);
  std::vector<std::uint32_t> roots;
  for (std::uint32_t c = 0; c < cells; ++c) {
    const std::uint32_t r = find(c);
    if (r == c) roots.push_back(c);
    root_weight_[r] += cell_weight_[c];
  }
  for (std::uint32_t c = 0; c < cells; ++c) parent_[c] = find(c);  // flat: parent_ is now the root
  *modes = roots.size();
  // The heaviest components become places (ties: the lower cell, for determinism).
  const std::size_t k = std::min(options_.max_places, roots.size());
  std::partial_sort(roots.begin(), roots.begin() + static_cast<std::ptrdiff_t>(k), roots.end(),
                    [&](std::uint32_t a, std::uint32_t b) {
                      return root_weight_[a] > root_weight_[b] || (root_weight_[a] == root_weight_[b] && a < b);
                    });
  root_rank_.assign(cells, -1);
  for (std::size_t r = 0; r < k; ++r) root_rank_[roots[r]] = static_cast<std::int32_t>(r);
  return k;
}

bool take_dominant_place(PoseEstimate& e, const PoseEstimateOptions& o) { return take_place(e, 0, o); }

std::size_t estimate_place(const std::vector<Place>& h, const Pose& prediction, double switch_ratio, double max_jump_m,
                           double max_jump_rad) {
  const auto continues = [&](const Place& place) {
    return (place.pose.translation() - prediction.translation()).norm() <= max_jump_m &&
           rotation_angle_between(place.pose.linear(), prediction.linear()) <= max_jump_rad;
  };
  if (h.empty() || continues(h.front())) return 0;
  for (std::size_t k = 1; k < h.size(); ++k) {
    if (continues(h[k])) return h.front().weight < switch_ratio * h[k].weight ? k : 0;
  }
  return 0;
}

bool take_place(PoseEstimate& e, std::size_t index, const PoseEstimateOptions& o) {
  if (index >= e.places.size()) throw Error("pose estimate: no place to take");
  const Place& top = e.places[index];
  if (!o.best_particle) e.pose = top.pose;
  e.covariance = top.covariance;
  e.place_weight = top.weight;
  e.place_particles = top.particles;
  e.std_position = top.std_position;
  e.std_rotation = top.std_rotation;
  e.inlier_ratio = top.inlier_ratio;
  e.see_through_ratio = top.see_through_ratio;
  e.coverage = top.coverage;
  return top.weight >= o.converged_weight && compact(top, o);
}

std::vector<PoseEstimator::Moments> PoseEstimator::moments(const ParticleArrays& p, const double* w, std::size_t n,
                                                           std::size_t k) const {
  const std::size_t chunks = (n + kDescribeChunk - 1) / kDescribeChunk;
  std::vector<Moments> part(chunks * k);
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t c = 0; c < static_cast<std::ptrdiff_t>(chunks); ++c) {
    Moments* sums = &part[static_cast<std::size_t>(c) * k];
    const std::size_t end = std::min(n, (static_cast<std::size_t>(c) + 1) * kDescribeChunk);
    for (std::size_t i = static_cast<std::size_t>(c) * kDescribeChunk; i < end; ++i) {
      const std::int32_t r = place_of(i);
      if (r < 0) continue;
      Moments& m = sums[static_cast<std::size_t>(r)];
      const Eigen::Quaternionf q = p.rotation(i);
      const Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
      m.rotation += w[i] * v * v.transpose();
      m.position += w[i] * p.position(i).cast<double>();
      m.weight += w[i];
      ++m.particles;
    }
  }
  std::vector<Moments> sum(k);
  for (std::size_t c = 0; c < chunks; ++c) {
    for (std::size_t r = 0; r < k; ++r) {
      const Moments& m = part[c * k + r];
      sum[r].rotation += m.rotation;
      sum[r].position += m.position;
      sum[r].weight += m.weight;
      sum[r].particles += m.particles;
    }
  }
  return sum;
}

std::vector<Place> PoseEstimator::describe(const ParticleArrays& p, const double* w, std::size_t n, std::size_t k,
                                           double total) const {
  // Two passes over the particles for all k places at once (means, then covariances), in parallel over fixed chunks
  // of particles whose sums are added in chunk order: the result does not depend on the threads.
  const std::size_t chunks = (n + kDescribeChunk - 1) / kDescribeChunk;
  const std::vector<Moments> sum = moments(p, w, n, k);
  std::vector<Place> h(k);
  std::vector<Eigen::Vector3d> mean_position(k);
  std::vector<Eigen::Quaterniond> inverse_mean(k);
  for (std::size_t r = 0; r < k; ++r) {
    h[r].particles = sum[r].particles;
    mean_position[r] = sum[r].position / sum[r].weight;
    const Eigen::Quaterniond mean_rotation = markley_mean(sum[r].rotation);
    inverse_mean[r] = mean_rotation.conjugate();
    h[r].pose.linear() = mean_rotation.toRotationMatrix();
    h[r].pose.translation() = mean_position[r];
  }
  std::vector<Matrix6d> cov_part(chunks * k, Matrix6d::Zero());
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t c = 0; c < static_cast<std::ptrdiff_t>(chunks); ++c) {
    Matrix6d* cov = &cov_part[static_cast<std::size_t>(c) * k];
    const std::size_t end = std::min(n, (static_cast<std::size_t>(c) + 1) * kDescribeChunk);
    for (std::size_t i = static_cast<std::size_t>(c) * kDescribeChunk; i < end; ++i) {
      const std::int32_t r = place_of(i);
      if (r < 0) continue;
      const auto rank = static_cast<std::size_t>(r);
      Eigen::Matrix<double, 6, 1> d;
      d.head<3>() = p.position(i).cast<double>() - mean_position[rank];
      d.tail<3>() = quaternion_log(inverse_mean[rank] * p.rotation(i).cast<double>());
      cov[rank] += w[i] * d * d.transpose();
    }
  }
  for (std::size_t r = 0; r < k; ++r) {
    Matrix6d cov = Matrix6d::Zero();
    for (std::size_t c = 0; c < chunks; ++c) cov += cov_part[c * k + r];
    h[r].covariance = cov / sum[r].weight;
    h[r].weight = sum[r].weight / total;
    h[r].std_position = largest_std(h[r].covariance.topLeftCorner<3, 3>());
    h[r].std_rotation = largest_std(h[r].covariance.bottomRightCorner<3, 3>());
  }
  return h;
}

}  // namespace tsdf_mcl
