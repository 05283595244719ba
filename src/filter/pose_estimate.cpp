#include "tsdf_mcl/pose_estimate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/motion_model.hpp"
#include "tsdf_mcl/random.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kTwoPi = 6.283185307179586;
constexpr std::uint32_t kNoCell = 0xFFFFFFFFu;

std::uint64_t cell_key(const Eigen::Vector4i& c) {
  std::uint64_t key = 0x51ED27A4u;
  for (int a = 0; a < 4; ++a) key = hash_combine(key, static_cast<std::uint64_t>(static_cast<std::int64_t>(c[a])));
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
}

Eigen::Quaterniond average_rotation(const std::vector<Eigen::Quaterniond>& rotations, const std::vector<double>& weights) {
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
  const double threshold = 1e-9 * w_max;

  // Cells of the (x, y, z, yaw) grid.
  std::size_t slots = 16;
  while (slots < 2 * n) slots *= 2;
  if (keys_.size() < slots) {
    keys_.resize(slots);
    slot_cell_.resize(slots);
  }
  slots = keys_.size();
  std::fill(keys_.begin(), keys_.end(), 0u);
  const auto lookup = [&](const Eigen::Vector4i& c, bool insert) -> std::uint32_t {
    const std::uint64_t key = cell_key(c);
    std::size_t s = static_cast<std::size_t>(key) & (slots - 1);
    while (keys_[s] != 0 && keys_[s] != key) s = (s + 1) & (slots - 1);
    if (keys_[s] != 0) return slot_cell_[s];
    if (!insert) return kNoCell;
    keys_[s] = key;
    slot_cell_[s] = static_cast<std::uint32_t>(cells_.size());
    cells_.push_back(c);
    cell_weight_.push_back(0.0);
    return slot_cell_[s];
  };
  cells_.clear();
  cell_weight_.clear();
  particle_cell_.resize(std::max(particle_cell_.size(), n));
  double total = 0.0;
  const float inv_xyz = 1.0f / options_.cluster_bin_xyz;
  for (std::size_t i = 0; i < n; ++i) {
    total += w[i];
    if (!(w[i] > threshold)) {
      particle_cell_[i] = kNoCell;
      continue;
    }
    const Eigen::Vector3f pos = p.position(i);
    const Eigen::Quaternionf q = p.rotation(i);
    // Yaw of the sensor's x axis in the world xy plane: defined for any tilt short of pointing straight up.
    const Eigen::Vector3f ax = q * Eigen::Vector3f::UnitX();
    const double yaw = std::atan2(ax.y(), ax.x());
    int yc = static_cast<int>(std::floor((yaw + kTwoPi / 2) / kTwoPi * yaw_cells_));
    yc = ((yc % yaw_cells_) + yaw_cells_) % yaw_cells_;
    const Eigen::Vector4i c(static_cast<int>(std::floor(pos.x() * inv_xyz)), static_cast<int>(std::floor(pos.y() * inv_xyz)),
                            static_cast<int>(std::floor(pos.z() * inv_xyz)), yc);
    const std::uint32_t cell = lookup(c, true);
    particle_cell_[i] = cell;
    cell_weight_[cell] += w[i];
  }

  // Connected components over face neighbours (one step along one axis; yaw wraps). Each cell looks up the
  // positive side only: the negative side is the same pairs seen from the other cell. The 80 diagonal
  // neighbours would join a little more, at ten times the cost, for the 100k cells of a global belief.
  const auto cells = static_cast<std::uint32_t>(cells_.size());
  parent_.resize(cells);
  for (std::uint32_t c = 0; c < cells; ++c) parent_[c] = c;
  for (std::uint32_t c = 0; c < cells; ++c) {
    for (int axis = 0; axis < 4; ++axis) {
      Eigen::Vector4i nb = cells_[c];
      nb[axis] += 1;
      nb[3] = nb[3] % yaw_cells_;
      const std::uint32_t other = lookup(nb, false);
      if (other == kNoCell) continue;
      const std::uint32_t ra = find(c);
      const std::uint32_t rb = find(other);
      if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  root_weight_.assign(cells, 0.0);
  PoseEstimate e;
  for (std::uint32_t c = 0; c < cells; ++c) {
    const std::uint32_t r = find(c);
    if (r == c) ++e.modes;
    root_weight_[r] += cell_weight_[c];
  }
  const auto mode = static_cast<std::uint32_t>(std::max_element(root_weight_.begin(), root_weight_.end()) - root_weight_.begin());
  for (std::uint32_t c = 0; c < cells; ++c) parent_[c] = find(c);  // flat: parent_ is now the root

  // The mode's weighted mean.
  double mode_weight = 0.0;
  Eigen::Vector3d position_sum = Eigen::Vector3d::Zero();
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (particle_cell_[i] == kNoCell || parent_[particle_cell_[i]] != mode) continue;
    const Eigen::Quaternionf q = p.rotation(i);
    const Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
    m += w[i] * v * v.transpose();
    position_sum += w[i] * p.position(i).cast<double>();
    mode_weight += w[i];
    ++e.mode_particles;
  }
  const Eigen::Vector3d mean_position = position_sum / mode_weight;
  const Eigen::Quaterniond mean_rotation = markley_mean(m);
  const Eigen::Quaterniond inverse_mean = mean_rotation.conjugate();
  Matrix6d cov = Matrix6d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (particle_cell_[i] == kNoCell || parent_[particle_cell_[i]] != mode) continue;
    Eigen::Matrix<double, 6, 1> d;
    d.head<3>() = p.position(i).cast<double>() - mean_position;
    d.tail<3>() = quaternion_log(inverse_mean * p.rotation(i).cast<double>());
    cov += w[i] * d * d.transpose();
  }
  e.covariance = cov / mode_weight;
  e.mode_weight = mode_weight / total;
  e.std_position = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                                               e.covariance.topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly)
                                               .eigenvalues()[2]));
  e.std_rotation = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                                               e.covariance.bottomRightCorner<3, 3>(), Eigen::EigenvaluesOnly)
                                               .eigenvalues()[2]));
  e.converged = e.mode_weight >= options_.converged_weight && e.std_position <= options_.converged_std_xyz &&
                e.std_rotation <= options_.converged_std_angle;
  e.pose = Pose::Identity();
  if (options_.best_particle) {
    e.pose.linear() = p.rotation(best).cast<double>().normalized().toRotationMatrix();
    e.pose.translation() = p.position(best).cast<double>();
  } else {
    e.pose.linear() = mean_rotation.toRotationMatrix();
    e.pose.translation() = mean_position;
  }
  return e;
}

}  // namespace tsdf_mcl
