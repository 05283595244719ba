#include "tsdf_mcl/filter/scan_gravity.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kDeg = kPi / 180.0;

// First and second moments of the points in one voxel.
struct Moments {
  double n = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  void add(const Eigen::Vector3d& p) {
    n += 1.0;
    sum += p;
    outer += p * p.transpose();
  }
  void add(const Moments& o) {
    n += o.n;
    sum += o.sum;
    outer += o.outer;
  }
};

// A planar patch of the scan: its centroid and unit normal (sign arbitrary).
struct Patch {
  Eigen::Vector3d centre;
  Eigen::Vector3d normal;
};

std::uint64_t voxel_key(int x, int y, int z) {
  const auto u = [](int v) {
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v + (1 << 20))) & 0x1FFFFFu;
  };
  return u(x) | (u(y) << 21) | (u(z) << 42);
}

// Open addressing over voxel keys: the scan's voxels and their moments (an unordered_map costs several times as
// much for the 27 neighbour lookups per voxel).
class VoxelMoments {
 public:
  explicit VoxelMoments(std::size_t points) {
    std::size_t slots = 64;
    while (slots < 2 * points) slots *= 2;
    keys_.assign(slots, kEmpty);
    index_.assign(slots, 0);
  }
  Moments& at(std::uint64_t key) {
    std::size_t s = slot(key);
    if (keys_[s] == kEmpty) {
      keys_[s] = key;
      index_[s] = static_cast<std::uint32_t>(moments_.size());
      moments_.emplace_back();
      order_.push_back(key);
    }
    return moments_[index_[s]];
  }
  const Moments* find(std::uint64_t key) const {
    const std::size_t s = slot(key);
    return keys_[s] == kEmpty ? nullptr : &moments_[index_[s]];
  }
  const std::vector<std::uint64_t>& keys() const { return order_; }  // in insertion order

 private:
  static constexpr std::uint64_t kEmpty = ~0ull;
  std::size_t slot(std::uint64_t key) const {
    std::size_t s = static_cast<std::size_t>(mix64(key)) & (keys_.size() - 1);
    while (keys_[s] != kEmpty && keys_[s] != key) s = (s + 1) & (keys_.size() - 1);
    return s;
  }
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> index_;
  std::vector<Moments> moments_;
  std::vector<std::uint64_t> order_;
};

std::vector<Patch> planar_patches(const std::vector<Eigen::Vector3f>& points, const GravityEstimation& o) {
  VoxelMoments voxels(points.size());
  const double inv = 1.0 / o.voxel;
  const double min2 = static_cast<double>(o.min_range) * o.min_range;
  const double max2 = static_cast<double>(o.max_range) * o.max_range;
  for (const Eigen::Vector3f& pf : points) {
    const Eigen::Vector3d p = pf.cast<double>();
    const double r2 = p.squaredNorm();
    if (!(r2 >= min2 && r2 <= max2)) continue;  // also drops NaN
    const auto c = [&](double v) { return static_cast<int>(std::floor(v * inv)); };
    voxels.at(voxel_key(c(p.x()), c(p.y()), c(p.z()))).add(p);
  }

  // Each voxel's fit reads the table only: in parallel, kept in the table's order (the same patches on any number
  // of threads).
  const std::vector<std::uint64_t>& keys = voxels.keys();
  std::vector<Patch> fitted(keys.size());
  std::vector<std::uint8_t> flat(keys.size(), 0);
#pragma omp parallel for schedule(static) if (keys.size() >= 256)
  for (std::ptrdiff_t kk = 0; kk < static_cast<std::ptrdiff_t>(keys.size()); ++kk) {
    const auto k = static_cast<std::size_t>(kk);
    const std::uint64_t key = keys[k];
    const int x = static_cast<int>(key & 0x1FFFFFu) - (1 << 20);
    const int y = static_cast<int>((key >> 21) & 0x1FFFFFu) - (1 << 20);
    const int z = static_cast<int>((key >> 42) & 0x1FFFFFu) - (1 << 20);
    Moments m;
    int filled = 0;
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const Moments* nb = voxels.find(voxel_key(x + dx, y + dy, z + dz));
          if (!nb) continue;
          m.add(*nb);
          ++filled;
        }
      }
    }
    if (m.n < 6.0 || filled < 3) continue;
    const Eigen::Vector3d mean = m.sum / m.n;
    const Eigen::Matrix3d cov = m.outer / m.n - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    const Eigen::Vector3d l = eig.eigenvalues();  // ascending
    // Flat (smallest spread far below the middle one) and not a line (a single far LiDAR ring): rings of
    // one beam are straight lines whose "normal" is arbitrary.
    if (!(l[0] < 0.05 * l[1] && l[1] > 0.05 * l[2])) continue;
    const Moments& own = *voxels.find(key);
    fitted[k] = {own.sum / own.n, eig.eigenvectors().col(0).normalized()};
    flat[k] = 1;
  }
  std::vector<Patch> patches;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (flat[k]) patches.push_back(fitted[k]);
  }
  return patches;
}

// Unit directions spread evenly over the upper hemisphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> hemisphere_directions(int count) {
  std::vector<Eigen::Vector3d> d;
  d.reserve(static_cast<std::size_t>(count));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (i + 0.5) / count;  // (0, 1]
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    d.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return d;
}

struct Axis {
  Eigen::Vector3d u;
  double parallel = 0.0;       // patches whose normal is parallel to u
  double perpendicular = 0.0;  // ... perpendicular to u
  double angle_std = 0.0;
  double score() const { return parallel + perpendicular; }
};

// Counts the support of `u` and refines it: the direction that the parallel normals point along and the
// perpendicular ones are orthogonal to, i.e. the least eigenvector of sum_perp n n^T - sum_par n n^T.
Axis refine_axis(Eigen::Vector3d u, const std::vector<Eigen::Vector3d>& normals, double tolerance) {
  const double cos_tol = std::cos(tolerance);
  const double sin_tol = std::sin(tolerance);
  Axis a;
  for (int iteration = 0; iteration < 3; ++iteration) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    a = Axis{u};
    double residual = 0.0;
    for (const Eigen::Vector3d& n : normals) {
      const double c = std::abs(n.dot(u));
      if (c >= cos_tol) {
        m -= n * n.transpose();
        a.parallel += 1.0;
        residual += 1.0 - c * c;
      } else if (c <= sin_tol) {
        m += n * n.transpose();
        a.perpendicular += 1.0;
        residual += c * c;
      }
    }
    if (a.score() < 3.0) return a;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(m);
    const Eigen::Vector3d v = eig.eigenvectors().col(0).normalized();
    u = v.dot(u) < 0.0 ? -v : v;
    // sin^2 of the patches' misalignment, averaged, over the supporting count: the mean's uncertainty.
    a.angle_std = std::sqrt(residual / a.score() / a.score());
  }
  a.u = u;
  return a;
}

// Height of the floor below the sensor along -up: the most supported plane below, or a lower one of at least
// a third of its support (a table top near the sensor can outnumber the floor around it).
bool floor_height(const std::vector<Patch>& patches, const Eigen::Vector3d& up, const GravityEstimation& o,
                  GravityCandidate& c) {
  const double cos_tol = std::cos(o.tolerance_deg * kDeg);
  constexpr double kBin = 0.05;
  std::vector<double> heights;
  for (const Patch& p : patches) {
    if (std::abs(p.normal.dot(up)) < cos_tol) continue;
    const double h = -p.centre.dot(up);
    if (h >= o.min_floor_height) heights.push_back(h);
  }
  if (heights.size() < o.min_floor_patches) return false;
  const double top = *std::max_element(heights.begin(), heights.end());
  const auto bins = static_cast<std::size_t>(top / kBin) + 2;
  std::vector<double> count(bins, 0.0);
  for (double h : heights) count[static_cast<std::size_t>(h / kBin)] += 1.0;
  std::vector<double> smooth(bins, 0.0);
  for (std::size_t b = 0; b < bins; ++b) {
    smooth[b] = count[b] + (b > 0 ? count[b - 1] : 0.0) + (b + 1 < bins ? count[b + 1] : 0.0);
  }
  const double peak = *std::max_element(smooth.begin(), smooth.end());
  std::size_t floor_bin = 0;
  for (std::size_t b = 0; b < bins; ++b) {
    if (smooth[b] >= peak / 3.0) floor_bin = b;
  }
  const double centre = (static_cast<double>(floor_bin) + 0.5) * kBin;
  std::vector<double> near;
  for (double h : heights) {
    if (std::abs(h - centre) <= 2.0 * kBin) near.push_back(h);
  }
  if (near.size() < o.min_floor_patches) return false;
  std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(near.size() / 2), near.end());
  const double median = near[near.size() / 2];
  std::vector<double> deviation;
  deviation.reserve(near.size());
  for (double h : near) deviation.push_back(std::abs(h - median));
  std::nth_element(deviation.begin(), deviation.begin() + static_cast<std::ptrdiff_t>(deviation.size() / 2),
                   deviation.end());
  c.has_height = true;
  c.height = static_cast<float>(median);
  // The spread of the floor's patches (ramps, noise) and a floor for what one scan cannot see: the map's floor
  // under the particle need not be the plane the scan saw a few metres away.
  c.height_std = static_cast<float>(std::max(0.05, 1.4826 * deviation[deviation.size() / 2]));
  c.floor_patches = near.size();
  return true;
}

// The levels that bound the scan along `up` from below (the floor) and above (the ceiling): robust extremes of
// the points' heights, each accepted where enough points share it. Unlike planar patches this needs no two rings
// on one surface, so it works for sparse LiDARs held high above the floor.
void bounding_levels(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& up, const GravityEstimation& o,
                     GravityCandidate& c) {
  const double min2 = static_cast<double>(o.min_range) * o.min_range;
  const double max2 = static_cast<double>(o.max_range) * o.max_range;
  std::vector<double> heights;
  heights.reserve(points.size());
  for (const Eigen::Vector3f& pf : points) {
    const Eigen::Vector3d p = pf.cast<double>();
    const double r2 = p.squaredNorm();
    if (r2 >= min2 && r2 <= max2) heights.push_back(p.dot(up));
  }
  if (heights.size() < 10 * o.min_level_points) return;
  const auto k =
      static_cast<std::ptrdiff_t>(static_cast<double>(o.level_quantile) * static_cast<double>(heights.size()));
  std::nth_element(heights.begin(), heights.begin() + k, heights.end());
  const double lowest = heights[static_cast<std::size_t>(k)];
  std::nth_element(heights.begin(), heights.end() - 1 - k, heights.end());
  const double highest = heights[heights.size() - 1 - static_cast<std::size_t>(k)];
  // A level is the median of the points within kBand of the extreme; its spread is the band (a level at the
  // 0.5 % quantile is only as sharp as the scan's noise and its tilt error let it be).
  constexpr double kBand = 0.1;  // m
  std::vector<double> near;
  const auto level = [&](double at, double* median) {
    near.clear();
    for (double h : heights) {
      if (std::abs(h - at) <= kBand) near.push_back(h);
    }
    if (near.size() < o.min_level_points) return false;
    std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(near.size() / 2), near.end());
    *median = near[near.size() / 2];
    return true;
  };
  double median = 0.0;
  if (!c.has_height && level(lowest, &median) && -median >= o.min_floor_height) {
    c.has_height = true;
    c.height = static_cast<float>(-median);
    c.height_std = static_cast<float>(kBand);
    c.floor_patches = 0;
  }
  if (level(highest, &median) && median >= o.min_floor_height) {
    c.has_ceiling = true;
    c.ceiling = static_cast<float>(median);
    c.ceiling_std = static_cast<float>(kBand);
  }
}

// Peaks of the normals' directions: greedy maxima of the parallel support, each suppressing its
// neighbourhood.
std::vector<Eigen::Vector3d> normal_peaks(const std::vector<Eigen::Vector3d>& normals, double tolerance) {
  const double cos_tol = std::cos(tolerance);
  // Voting needs no more than ~1000 normals (evenly strided); the refinement (candidate_axes) uses all of them.
  const std::vector<Eigen::Vector3d> directions = hemisphere_directions(1500);
  const std::size_t stride = std::max<std::size_t>(1, normals.size() / 1000);
  std::vector<double> support(directions.size(), 0.0);
  for (std::size_t d = 0; d < directions.size(); ++d) {
    for (std::size_t i = 0; i < normals.size(); i += stride) {
      support[d] += std::abs(normals[i].dot(directions[d])) >= cos_tol ? 1.0 : 0.0;
    }
  }
  std::vector<Eigen::Vector3d> peaks;
  for (int k = 0; k < 6; ++k) {
    const auto best = static_cast<std::size_t>(std::max_element(support.begin(), support.end()) - support.begin());
    if (support[best] < 0.02 * static_cast<double>((normals.size() + stride - 1) / stride)) break;
    peaks.push_back(directions[best]);
    for (std::size_t d = 0; d < directions.size(); ++d) {
      if (std::abs(directions[d].dot(directions[best])) >= std::cos(2.0 * tolerance)) support[d] = 0.0;
    }
  }
  return peaks;
}

// Candidate axes, best supported first: the peaks (floors, ceilings, walls) and the normals of pairs of
// near-orthogonal peaks (the up axis of a scan that sees walls in two directions and little floor), each refined
// on all normals; near-duplicates keep the better one.
std::vector<Axis> candidate_axes(const std::vector<Eigen::Vector3d>& peaks, const std::vector<Eigen::Vector3d>& normals,
                                 double tolerance) {
  std::vector<Eigen::Vector3d> seeds = peaks;
  for (std::size_t a = 0; a < peaks.size(); ++a) {
    for (std::size_t b = a + 1; b < peaks.size(); ++b) {
      if (std::abs(peaks[a].dot(peaks[b])) < 0.5) seeds.push_back(peaks[a].cross(peaks[b]).normalized());
    }
  }
  std::vector<Axis> axes;
  for (const Eigen::Vector3d& seed : seeds) {
    const Axis a = refine_axis(seed, normals, tolerance);
    if (a.score() < 3.0) continue;
    bool duplicate = false;
    for (Axis& other : axes) {
      if (std::abs(other.u.dot(a.u)) >= std::cos(2.0 * tolerance)) {
        duplicate = true;
        if (a.score() > other.score()) other = a;
      }
    }
    if (!duplicate) axes.push_back(a);
  }
  std::stable_sort(axes.begin(), axes.end(), [](const Axis& a, const Axis& b) { return a.score() > b.score(); });
  return axes;
}

std::vector<Eigen::Vector3f> towards_sensor(const std::vector<Patch>& patches) {
  std::vector<Eigen::Vector3f> normals;
  normals.reserve(patches.size());
  for (const Patch& p : patches) {
    const Eigen::Vector3d n = p.normal.dot(p.centre) > 0.0 ? -p.normal : p.normal;
    normals.push_back(n.cast<float>());
  }
  return normals;
}

}  // namespace

std::vector<Eigen::Vector3f> planar_normals(const std::vector<Eigen::Vector3f>& points, const GravityEstimation& o) {
  o.validate();
  return towards_sensor(planar_patches(points, o));
}

void GravityEstimation::validate() const {
  if (!(min_range >= 0.0f && max_range > min_range && std::isfinite(max_range))) {
    throw Error("gravity estimation: needs 0 <= min_range < max_range");
  }
  if (!(voxel > 0.0f && std::isfinite(voxel))) throw Error("gravity estimation: voxel must be positive");
  if (!(tolerance_deg > 0.0f && tolerance_deg < 45.0f))
    throw Error("gravity estimation: tolerance_deg must lie in (0, 45)");
  if (max_axes == 0) throw Error("gravity estimation: max_axes must be at least 1");
  if (!(min_relative_support > 0.0f && min_relative_support <= 1.0f)) {
    throw Error("gravity estimation: min_relative_support must lie in (0, 1]");
  }
  if (!(level_quantile >= 0.0f && level_quantile < 0.5f))
    throw Error("gravity estimation: level_quantile must lie in [0, 0.5)");
}

GravityEstimate estimate_gravity(const std::vector<Eigen::Vector3f>& points, const GravityEstimation& o,
                                 const std::optional<Eigen::Vector3f>& known_up) {
  o.validate();
  GravityEstimate result;
  const std::vector<Patch> patches = planar_patches(points, o);
  result.planar_patches = patches.size();
  result.normals = towards_sensor(patches);
  if (patches.size() < o.min_planar_patches) return result;
  const double tolerance = o.tolerance_deg * kDeg;
  std::vector<Eigen::Vector3d> normals;
  normals.reserve(patches.size());
  for (const Patch& p : patches) normals.push_back(p.normal);
  const auto total = static_cast<double>(patches.size());
  const auto add_candidates = [&](const Axis& a, std::initializer_list<double> signs) {
    for (const double sign : signs) {
      GravityCandidate c;
      const Eigen::Vector3d up = sign * a.u;
      c.up = up.cast<float>();
      c.support = static_cast<float>(a.score() / total);
      c.angle_std = static_cast<float>(std::clamp(a.angle_std, 0.5 * kDeg, 10.0 * kDeg));
      floor_height(patches, up, o, c);
      bounding_levels(points, up, o, c);
      result.candidates.push_back(c);
    }
  };
  if (known_up) {
    const Axis a = refine_axis(known_up->cast<double>().normalized(), normals, tolerance);
    add_candidates(Axis{known_up->cast<double>().normalized(), a.parallel, a.perpendicular, a.angle_std}, {1.0});
    return result;
  }

  const std::vector<Axis> axes = candidate_axes(normal_peaks(normals, tolerance), normals, tolerance);
  if (axes.empty()) return result;
  const double best = axes.front().score();
  for (std::size_t k = 0; k < axes.size() && k < o.max_axes; ++k) {
    if (axes[k].score() < o.min_relative_support * best) break;
    add_candidates(axes[k], {1.0, -1.0});
  }
  return result;
}

Eigen::Vector3f refine_up_axis(const std::vector<Eigen::Vector3f>& normals, const Eigen::Vector3f& guess,
                               float tolerance_deg) {
  std::vector<Eigen::Vector3d> n;
  n.reserve(normals.size());
  for (const Eigen::Vector3f& v : normals) n.push_back(v.cast<double>().normalized());
  const Axis a = refine_axis(guess.cast<double>().normalized(), n, tolerance_deg * kDeg);
  // Too little support (fewer than a fifth of the normals): the guess stands.
  if (a.score() < 0.2 * static_cast<double>(n.size())) return guess.normalized();
  const Eigen::Vector3d u = a.u.dot(guess.cast<double>()) < 0.0 ? -a.u : a.u;
  return u.cast<float>();
}

}  // namespace tsdf_mcl
