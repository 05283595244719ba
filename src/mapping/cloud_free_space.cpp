// The cloud map builder's stage 5: free space carved along sight lines and enclosed regions filled, then the map
// assembled (cloud_builder.hpp).
#include "block_face.hpp"
#include "cloud_builder.hpp"

namespace tsdf_mcl::cloud_build {

void Builder::carve() {
  std::vector<SightLine> lines;
  if (!keyposes_.empty()) {
    for (std::uint32_t i = 0; i < w_.size(); ++i) {
      for (std::uint32_t k : w_.viewpoint[i]) {
        if (k != kNone) lines.push_back({keyposes_.points()[k], w_.anchor[i]});
      }
    }
  } else {
    for (const auto& [i, j] : surface_hits_) {
      // Only between surfaces facing each other (or sheets without a side).
      if (w_.is_signed(j) && w_.normal[j].dot(w_.anchor[i] - w_.anchor[j]) <= 0.0f) continue;
      lines.push_back({w_.anchor[i], w_.anchor[j]});
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(surface_hits_);
  }
  budget_.charge(lines.size() * sizeof(SightLine), "sight lines");
  report_.sight_lines = lines.size();
  const float stop = 0.5f * vs_;
  std::atomic<std::size_t> done{0};
  const std::size_t batch = 4096;
  parallel_blocks((lines.size() + batch - 1) / batch, [&](std::size_t k) {
    const std::size_t end = std::min(lines.size(), (k + 1) * batch);
    for (std::size_t s = k * batch; s < end; ++s) {
      const Vector3f ray = lines[s].to - lines[s].from;
      const float length = ray.norm() - stop;
      if (!(length > 0.0f)) continue;
      const Vector3f dir = ray.normalized();
      walk_until(lines[s].from, dir, 0.0f, length, vs_, B, [&](const Vector3i& block, float t_in, float t_out) {
        const std::int64_t cell = map_.coarse_cell(block);
        if (cell < 0) return true;
        const std::uint32_t slot = slot_[static_cast<std::size_t>(cell)];
        if (slot == kNone) {
          free_[static_cast<std::size_t>(cell)].store(1, std::memory_order_relaxed);
          return true;
        }
        BandBlock& b = band_[slot];
        walk_until(lines[s].from, dir, t_in, t_out, vs_, 1, [&](const Vector3i& v, float, float) {
          if (block_of(v) != block) return true;
          const int l = local_of(v);
          std::atomic<std::uint8_t>& c = b.crossed[static_cast<std::size_t>(l)];
          std::uint8_t n = c.load(std::memory_order_relaxed);
          while (n < 255 && !c.compare_exchange_weak(n, static_cast<std::uint8_t>(n + 1), std::memory_order_relaxed)) {
          }
          return true;
        });
        return true;
      });
    }
    const std::size_t d = done.fetch_add(end - k * batch) + (end - k * batch);
    if (omp_get_thread_num() == 0)
      progress_(4, static_cast<double>(d) / static_cast<double>(std::max<std::size_t>(1, lines.size())));
  });
}

void Builder::fill_enclosed() {
  const Vector3i dims = map_.dims_blocks();
  const std::int64_t cells = static_cast<std::int64_t>(slot_.size());
  const std::int64_t stride[3] = {1, dims.x(), static_cast<std::int64_t>(dims.x()) * dims.y()};
  std::vector<std::uint8_t> visited(slot_.size(), 0);
  std::vector<std::int64_t> component;
  for (std::int64_t seed = 0; seed < cells; ++seed) {
    const auto s = static_cast<std::size_t>(seed);
    if (visited[s] || slot_[s] != kNone || free_[s].load(std::memory_order_relaxed)) continue;
    component.clear();
    component.push_back(seed);
    visited[s] = 1;
    bool border = false;
    std::int64_t positive = 0, negative = 0;
    for (std::size_t next = 0; next < component.size(); ++next) {
      const std::int64_t cell = component[next];
      const Vector3i rel(static_cast<int>(cell % dims.x()), static_cast<int>((cell / dims.x()) % dims.y()),
                         static_cast<int>(cell / stride[2]));
      for (int axis = 0; axis < 3; ++axis) {
        for (int dir : {-1, 1}) {
          const int r = rel[axis] + dir;
          if (r < 0 || r >= dims[axis]) {
            border = true;
            continue;
          }
          const std::int64_t nbr = cell + dir * stride[axis];
          const auto ns = static_cast<std::size_t>(nbr);
          if (free_[ns].load(std::memory_order_relaxed)) {
            positive += B * B;
            continue;
          }
          if (slot_[ns] == kNone) {
            if (!visited[ns]) {
              visited[ns] = 1;
              component.push_back(nbr);
            }
            continue;
          }
          // The band block's voxel layer facing this block.
          const BandBlock& b = band_[slot_[ns]];
          for_each_facing_voxel(axis, dir, [&](int li) {
            const std::int16_t q = b.q[static_cast<std::size_t>(li)];
            if (q == TsdfMap::kUnknownValue || (b.unsure[static_cast<std::size_t>(li >> 6)] >> (li & 63) & 1)) return;
            positive += q > 0;
            negative += q < 0;
          });
        }
      }
    }
    if (!border && positive > negative) {
      for (std::int64_t cell : component) free_[static_cast<std::size_t>(cell)].store(2, std::memory_order_relaxed);
    }
  }
}

TsdfMap Builder::assemble() {
  const float vs = vs_;
  const std::int16_t full = map_.quantize(trunc_);
  std::array<std::int16_t, kVoxels> values;
  for (std::size_t s = 0; s < band_.size(); ++s) {
    const BandBlock& b = band_[s];
    for (int l = 0; l < kVoxels; ++l) {
      const auto li = static_cast<std::size_t>(l);
      const int crossed = b.crossed[li].load(std::memory_order_relaxed);
      const bool freed = crossed > 0;
      const bool unsure = b.unsure[li >> 6] >> (l & 63) & 1;
      std::int16_t q = b.q[li];
      if (q == TsdfMap::kUnknownValue) {
        q = freed ? full : TsdfMap::kUnknownValue;
      } else if (unsure && !freed && map_.dequantize(q) > 0.5f * vs) {
        q = TsdfMap::kUnknownValue;
      } else if (q < 0 && crossed >= kMinCrossings && map_.dequantize(q) <= -2.0f * vs) {
        // Behind a surface seen from one side only, yet sight lines pass: the far side of something thin (a desk
        // top seen from below), free. Within two voxels of the surface its own sign stands.
        q = static_cast<std::int16_t>(-q);
      }
      values[li] = q;
    }
    map_.set_block(band_block_[s], values);
  }
  const Vector3i dims = map_.dims_blocks();
  for (std::size_t c = 0; c < slot_.size(); ++c) {
    if (slot_[c] != kNone || !free_[c].load(std::memory_order_relaxed)) continue;
    const auto cc = static_cast<std::int64_t>(c);
    map_.mark_block_free(map_.min_block() +
                         Vector3i(static_cast<int>(cc % dims.x()), static_cast<int>((cc / dims.x()) % dims.y()),
                                  static_cast<int>(cc / (static_cast<std::int64_t>(dims.x()) * dims.y()))));
  }
  std::deque<BandBlock>().swap(band_);
  map_.compact();
  report_.free_blocks = map_.stats().free_blocks;
  progress_(5, 0.5);
  return std::move(map_);
}

void Builder::count_surface(const TsdfMap& map) {
  std::uint64_t surface = 0;
#pragma omp parallel for reduction(+ : surface) schedule(static)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(w_.size()); ++i) {
    const TsdfMap::Sample s = map.trilinear(w_.anchor[static_cast<std::size_t>(i)]);
    if (s.known && std::abs(s.distance) <= vs_) surface += w_.count[static_cast<std::size_t>(i)];
  }
  report_.surface_points = surface;
  progress_(5, 1.0);
}

}  // namespace tsdf_mcl::cloud_build
