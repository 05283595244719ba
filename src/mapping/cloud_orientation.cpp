// The cloud map builder's stages 2 and 3: a normal per working point, and which side of it is free (cloud_builder.hpp).
#include "cloud_builder.hpp"

namespace tsdf_mcl::cloud_build {

void Builder::fit_normals() {
  const std::size_t n = w_.size();
  budget_.charge(n * (sizeof(Vector3f) + 2 + sizeof(Source) + sizeof(float) + 8), "the working points' normals");
  w_.normal.assign(n, Vector3f::Zero());
  w_.flags.assign(n, 0);
  w_.orient.assign(n, 0);
  w_.source.assign(n, Source::kUnknown);
  w_.confidence.assign(n, 0.0f);
  w_.viewpoint.assign(n, {kNone, kNone});
  const std::vector<Vector3f> centroid = w_.anchor;
  const float sheet = kSheet * vs_;
  const auto& blocks = grid_.blocks();
  parallel_blocks(blocks.size(), [&](std::size_t k) {
    const Neighbourhood nb(grid_, blocks[k].block);
    const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
    std::vector<Vector3f> near;
    for (std::uint32_t i = blocks[k].first; i < end; ++i) {
      near.clear();
      near.push_back(centroid[i]);
      for_each_neighbour(nb, w_.voxel[i], i, [&](std::uint32_t j) { near.push_back(centroid[j]); });
      Vector3f normal, mean;
      Vector3f lambda;
      if (!pca(near, nullptr, 0.0f, normal, mean, lambda)) continue;
      // Again over the sheet of the first plane only.
      if (!pca(near, &normal, sheet, normal, mean, lambda)) continue;
      const bool flat = lambda[0] <= 0.3f * lambda[1];
      const bool wide = lambda[1] >= 0.1f * lambda[2];
      if (!(flat && wide)) continue;
      w_.normal[i] = normal;
      w_.flags[i] = kPlanar;
      w_.anchor[i] = centroid[i] + normal * normal.dot(mean - centroid[i]);
    }
  });
  progress_(1, 1.0);
}

bool Builder::pca(const std::vector<Vector3f>& points, const Vector3f* plane, float sheet, Vector3f& normal,
                  Vector3f& mean, Vector3f& lambda) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int used = 0;
  const Vector3f origin = points[0];
  auto take = [&](const Vector3f& p) { return !plane || std::abs(plane->dot(p - origin)) <= sheet; };
  for (const Vector3f& p : points) {
    if (!take(p)) continue;
    sum += (p - origin).cast<double>();
    ++used;
  }
  if (used < 5) return false;
  const Eigen::Vector3d m = sum / used;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vector3f& p : points) {
    if (!take(p)) continue;
    const Eigen::Vector3d d = (p - origin).cast<double>() - m;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov / used);
  normal = es.eigenvectors().col(0).cast<float>().normalized();
  lambda = es.eigenvalues().cast<float>();
  mean = origin + m.cast<float>();
  return normal.allFinite();
}

bool Builder::sees(std::uint32_t i, const Vector3f& target) const {
  const Vector3f& p = w_.anchor[i];
  const Vector3f ray = target - p;
  const float length = ray.norm();
  if (!(length > 0.0f)) return true;
  const Vector3f dir = ray / length;
  const bool planar = w_.flags[i] & kPlanar;
  const Vector3f& n = w_.normal[i];
  const float sheet = kSheet * vs_, near2 = 4.0f * vs_ * vs_;
  return trace(grid_, vs_, p, dir, length, [&](std::uint32_t j, float) {
    if (j == i) return true;
    const Vector3f d = w_.anchor[j] - p;
    return planar ? std::abs(n.dot(d)) <= sheet : d.squaredNorm() <= near2;
  });
}

void Builder::orient_by_trajectory() {
  const std::size_t n = w_.size();
  const auto& poses = keyposes_.points();
  const float range2 = o_.max_range * o_.max_range;
  std::atomic<std::size_t> done{0};
  const auto& blocks = grid_.blocks();
  parallel_blocks(blocks.size(), [&](std::size_t k) {
    const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
    std::uint32_t index[kCandidates];
    float dist2[kCandidates];
    for (std::uint32_t i = blocks[k].first; i < end; ++i) {
      const Vector3f& p = w_.anchor[i];
      const std::size_t found = keyposes_.nearest(p, kCandidates, index, dist2);
      const bool planar = w_.flags[i] & kPlanar;
      int side[2] = {0, 0};  // positions seeing the point in front of (0) and behind (1) its normal
      std::uint32_t seen[2][2] = {{kNone, kNone}, {kNone, kNone}};  // the first two seeing each side
      for (std::size_t c = 0; c < found && dist2[c] <= range2; ++c) {
        const Vector3f& pose = poses[index[c]];
        if (!sees(i, pose)) continue;
        const float cosine = planar ? w_.normal[i].dot(pose - p) / std::sqrt(dist2[c]) : 1.0f;
        const int s = cosine >= 0.0f ? 0 : 1;
        std::uint32_t* slot = seen[s];
        if (slot[0] == kNone)
          slot[0] = index[c];
        else if (slot[1] == kNone)
          slot[1] = index[c];
        if (!planar) {
          if (slot[1] != kNone) break;
          continue;
        }
        // Within ~6 deg of the plane a position tells nothing about the side.
        if (std::abs(cosine) < 0.1f) continue;
        if (++side[s] >= 3) break;
      }
      // Two sight lines per point (more lines cross the space over thin things seen from one side).
      w_.viewpoint[i] = {seen[0][0], seen[0][1]};
      if (!planar) continue;
      if (std::min(side[0], side[1]) >= 2) {
        w_.flags[i] |= kTwoSided;
        w_.viewpoint[i] = {seen[0][0], seen[1][0]};  // one from each side
      } else if (side[0] != side[1]) {
        const int front = side[1] > side[0] ? 1 : 0;
        if (front == 1) w_.normal[i] = -w_.normal[i];
        w_.viewpoint[i] = {seen[front][0], seen[front][1]};
        w_.orient[i] = 1;
        w_.source[i] = Source::kTrajectory;
        w_.confidence[i] = 1.0f + static_cast<float>(std::abs(side[0] - side[1]));
      } else {
        w_.viewpoint[i] = {seen[0][0], seen[1][0]};
      }
    }
    const std::size_t d = done.fetch_add(end - blocks[k].first) + (end - blocks[k].first);
    if (omp_get_thread_num() == 0) progress_(2, static_cast<double>(d) / static_cast<double>(n));
  });
}

Builder::SightVotes Builder::look_both_ways(std::uint32_t i, const std::vector<Vector3f>& dirs, const Vector3f& lo,
                                            const Vector3f& hi, float near, float sheet) const {
  const Vector3f& p = w_.anchor[i];
  const Vector3f& nrm = w_.normal[i];
  SightVotes votes;
  votes.seen.fill(kNone);
  for (std::size_t d = 0; d < dirs.size(); ++d) {
    const float c = dirs[d].dot(nrm);
    if (std::abs(c) < 0.5f) continue;
    const int s = c > 0.0f ? 0 : 1;
    // To the first point off this point's sheet, or out of the cloud's box.
    float length = o_.max_range;
    for (int a = 0; a < 3; ++a) {
      if (dirs[d][a] > 0.0f) length = std::min(length, (hi[a] + vs_ - p[a]) / dirs[d][a]);
      if (dirs[d][a] < 0.0f) length = std::min(length, (lo[a] - vs_ - p[a]) / dirs[d][a]);
    }
    std::uint32_t hit = kNone;
    float at = 0.0f;
    trace(grid_, vs_, p, dirs[d], std::max(length, 0.0f), [&](std::uint32_t j, float t) {
      if (j == i || std::abs(nrm.dot(w_.anchor[j] - p)) <= sheet) return true;
      hit = j;
      at = t;
      return false;
    });
    if (hit == kNone) continue;  // escaped: unobserved space, no vote
    if (at < near && std::abs(w_.normal[hit].dot(nrm)) > 0.7f) {
      ++votes.close[s];
    } else if (at >= near) {
      ++votes.far[s];
      votes.seen[d] = hit;
    }
  }
  return votes;
}

bool Builder::orient_by_votes(std::uint32_t i, const SightVotes& votes) {
  const int score0 = votes.far[0] - 2 * votes.close[0], score1 = votes.far[1] - 2 * votes.close[1];
  if (votes.far[0] >= 2 && votes.far[1] >= 2 && votes.close[0] + votes.close[1] == 0) {
    w_.flags[i] |= kTwoSided;
  } else if (std::abs(score0 - score1) >= 2) {
    if (score1 > score0) w_.normal[i] = -w_.normal[i];
    w_.orient[i] = 1;
    w_.source[i] = Source::kVisibility;
    w_.confidence[i] = 0.5f * static_cast<float>(std::abs(score0 - score1));
  } else {
    return false;
  }
  return true;
}

void Builder::orient_by_visibility() {
  const std::size_t n = w_.size();
  const std::vector<Vector3f> dirs = sphere_directions(24);
  Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const Vector3f& p : w_.anchor) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const float near = std::max(kNearHit, 3.0f * vs_), sheet = kSheet * vs_;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> hits(
      static_cast<std::size_t>(omp_get_max_threads()));
  std::atomic<std::size_t> done{0};
  const auto& blocks = grid_.blocks();
  parallel_blocks(blocks.size(), [&](std::size_t k) {
    const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
    auto& my_hits = hits[static_cast<std::size_t>(omp_get_thread_num())];
    for (std::uint32_t i = blocks[k].first; i < end; ++i) {
      if (!(w_.flags[i] & kPlanar)) continue;
      const Vector3i& v = w_.voxel[i];
      if (((static_cast<std::uint32_t>(v.x()) * 73856093u) ^ (static_cast<std::uint32_t>(v.y()) * 19349663u) ^
           (static_cast<std::uint32_t>(v.z()) * 83492791u)) %
              4 !=
          0) {
        continue;
      }
      const SightVotes votes = look_both_ways(i, dirs, lo, hi, near, sheet);
      if (!orient_by_votes(i, votes)) continue;
      // The open sides' sight lines, to carve once every point is oriented.
      for (std::size_t d = 0; d < dirs.size(); ++d) {
        if (votes.seen[d] == kNone) continue;
        if ((w_.flags[i] & kTwoSided) || dirs[d].dot(w_.normal[i]) > 0.0f) my_hits.emplace_back(i, votes.seen[d]);
      }
    }
    const std::size_t d = done.fetch_add(end - blocks[k].first) + (end - blocks[k].first);
    if (omp_get_thread_num() == 0) progress_(2, static_cast<double>(d) / static_cast<double>(n));
  });
  for (auto& h : hits) {
    budget_.charge(h.size() * sizeof(h[0]), "sight lines between surfaces");
    surface_hits_.insert(surface_hits_.end(), h.begin(), h.end());
  }
  std::sort(surface_hits_.begin(), surface_hits_.end());
}

void Builder::propagate_orientation() {
  const std::size_t n = w_.size();
  using Item = std::pair<float, std::uint32_t>;
  std::priority_queue<Item> queue;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (w_.is_signed(i)) queue.emplace(w_.confidence[i], i);
  }
  const float sheet = kSheet * vs_;
  while (!queue.empty()) {
    const auto [conf, i] = queue.top();
    queue.pop();
    if (conf < w_.confidence[i]) continue;
    const Vector3i& v = w_.voxel[i];
    for (int dz = -kRadius; dz <= kRadius; ++dz)
      for (int dy = -kRadius; dy <= kRadius; ++dy)
        for (int dx = -kRadius; dx <= kRadius; ++dx) {
          const Vector3i u = v + Vector3i(dx, dy, dz);
          const GridBlock* g = last_block(u);
          const std::uint32_t j = g ? g->find(local_of(u)) : kNone;
          if (j == kNone || j == i || w_.source[j] == Source::kTrajectory || w_.source[j] == Source::kVisibility)
            continue;
          if (!(w_.flags[j] & kPlanar) || (w_.flags[j] & kTwoSided)) continue;
          const float dot = w_.normal[i].dot(w_.normal[j]);
          if (std::abs(dot) < 0.7f || std::abs(w_.normal[i].dot(w_.anchor[j] - w_.anchor[i])) > sheet) continue;
          const float c = conf * std::abs(dot) * 0.95f;
          if (c <= w_.confidence[j]) continue;
          if (dot < 0.0f) w_.normal[j] = -w_.normal[j];
          w_.orient[j] = 1;
          w_.source[j] = Source::kPropagation;
          w_.confidence[j] = c;
          queue.emplace(c, j);
        }
  }
}

const GridBlock* Builder::last_block(const Vector3i& v) {
  const Vector3i b = block_of(v);
  if (b != cached_block_) {
    cached_block_ = b;
    cached_ = grid_.block(b);
  }
  return cached_;
}

void Builder::count_kinds() {
  for (std::size_t i = 0; i < w_.size(); ++i) {
    if (w_.flags[i] & kPlanar) ++report_.planar;
    if (w_.flags[i] & kTwoSided) ++report_.two_sided;
    if (!w_.is_signed(i)) ++report_.unsigned_points;
    switch (w_.source[i]) {
      case Source::kTrajectory:
        ++report_.oriented_by_trajectory;
        break;
      case Source::kVisibility:
        ++report_.oriented_by_visibility;
        break;
      case Source::kPropagation:
        ++report_.oriented_by_propagation;
        break;
      case Source::kUnknown:
        break;
    }
  }
  progress_(3, 0.0);
}

}  // namespace tsdf_mcl::cloud_build
