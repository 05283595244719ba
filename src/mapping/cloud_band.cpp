// The cloud map builder's stage 4: the band of voxels around the surfaces, nearest points and signed distances
// (cloud_builder.hpp).
#include "cloud_builder.hpp"

namespace tsdf_mcl::cloud_build {

void Builder::make_box() {
  Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const Vector3f& p : w_.anchor) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  for (const auto& vp : w_.viewpoint) {
    for (std::uint32_t k : vp) {
      if (k == kNone) continue;
      lo = lo.cwiseMin(keyposes_.points()[k]);
      hi = hi.cwiseMax(keyposes_.points()[k]);
    }
  }
  const float border = trunc_ + 2.0f * vs_ + o_.margin;
  const Vector3f box_lo = lo.array() - border, box_hi = hi.array() + border;
  // Per cell: the band slot, the free mark, the fill's queue entry and mark, the map's coarse entry.
  budget_.charge(
      TsdfMap::box_cells(vs_, trunc_, box_lo, box_hi) * (3 * sizeof(std::uint32_t) + 2 + sizeof(std::int64_t)),
      "the cloud's box in blocks");
  map_ = TsdfMap::covering(vs_, trunc_, box_lo, box_hi);
  slot_.assign(map_.coarse_index().size(), kNone);
  free_ = std::make_unique<std::atomic<std::uint8_t>[]>(slot_.size());
  for (std::size_t c = 0; c < slot_.size(); ++c) free_[c].store(0, std::memory_order_relaxed);
}

std::uint32_t Builder::slot_of(const Vector3i& block, bool allocate) {
  const std::int64_t cell = map_.coarse_cell(block);
  if (cell < 0) return kNone;
  std::uint32_t& s = slot_[static_cast<std::size_t>(cell)];
  if (s == kNone && allocate) {
    budget_.charge(
        sizeof(FireBlock) + sizeof(BandBlock) + TsdfMap::kWordsPerBlock * sizeof(std::uint32_t) + sizeof(Vector3i),
        "blocks near the surface");
    s = static_cast<std::uint32_t>(fire_.size());
    fire_.emplace_back();
    band_block_.push_back(block);
  }
  return s;
}

void Builder::brushfire() {
  const int layers = static_cast<int>(std::ceil(trunc_ / vs_));
  // A layer holds about as many voxels as both sides of the surfaces: a few per working point.
  budget_.charge(w_.size() * 6 * sizeof(std::uint64_t), "the brushfire's layers");
  std::vector<std::uint64_t> frontier, next;
  frontier.reserve(w_.size());
  for (std::uint32_t i = 0; i < w_.size(); ++i) {
    const Vector3i& v = w_.voxel[i];
    const std::uint32_t s = slot_of(block_of(v), true);
    fire_[s].nearest[static_cast<std::size_t>(local_of(v))] = i;
    frontier.push_back(std::uint64_t{s} << 9 | static_cast<std::uint64_t>(local_of(v)));
  }
  constexpr std::uint32_t kUnset = kNone - 1;
  for (int layer = 1; !frontier.empty(); ++layer) {
    const bool band = layer <= layers;
    const auto mark = static_cast<std::uint8_t>(std::min(layer, 255));
    next.clear();
    std::uint32_t cached = kNone;
    std::array<std::uint32_t, 27> around{};
    for (const std::uint64_t entry : frontier) {
      const auto s = static_cast<std::uint32_t>(entry >> 9);
      const int l = static_cast<int>(entry & 511);
      if (s != cached) {
        cached = s;
        around.fill(kUnset);
      }
      const std::uint32_t i = fire_[s].nearest[static_cast<std::size_t>(l)];
      const Vector3i lv(l & 7, (l >> 3) & 7, l >> 6);
      for (int k = 0; k < 27; ++k) {
        if (k == 13) continue;
        const Vector3i u = lv + Vector3i(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1);
        const Vector3i offset(u.x() >> 3, u.y() >> 3, u.z() >> 3);
        const int c = (offset.x() + 1) + 3 * ((offset.y() + 1) + 3 * (offset.z() + 1));
        std::uint32_t& t = around[static_cast<std::size_t>(c)];
        if (t == kUnset) t = slot_of(band_block_[s] + offset, band);
        if (t == kNone) continue;
        FireBlock& f = fire_[t];
        const int ul = (u.x() & 7) + B * ((u.y() & 7) + B * (u.z() & 7));
        std::uint32_t& cur = f.nearest[static_cast<std::size_t>(ul)];
        if (cur == kNone) {
          cur = i;
          f.layer[static_cast<std::size_t>(ul)] = mark;
          next.push_back(std::uint64_t{t} << 9 | static_cast<std::uint64_t>(ul));
        } else if (band && f.layer[static_cast<std::size_t>(ul)] == mark && cur != i) {
          const Vector3f x =
              ((band_block_[t] * B).cast<float>() +
               Vector3f(static_cast<float>(ul & 7), static_cast<float>((ul >> 3) & 7), static_cast<float>(ul >> 6))) *
              vs_;
          if ((x - w_.anchor[i]).squaredNorm() < (x - w_.anchor[cur]).squaredNorm()) cur = i;
        }
      }
    }
    frontier.swap(next);
    if (band) progress_(3, 0.8 * layer / layers);
  }
}

void Builder::signed_distances() {
  for (std::size_t s = 0; s < fire_.size(); ++s) band_.emplace_back();
  report_.band_blocks = fire_.size();
  const float foot = vs_, trunc = trunc_;
  parallel_blocks(fire_.size(), [&](std::size_t s) {
    const FireBlock& f = fire_[s];
    BandBlock& b = band_[s];
    const Neighbourhood nb(grid_, band_block_[s]);
    const Vector3i first = band_block_[s] * B;
    for (int l = 0; l < kVoxels; ++l) {
      const std::uint32_t i = f.nearest[static_cast<std::size_t>(l)];
      if (i == kNone) continue;
      const Vector3f x = (first + Vector3i(l % B, (l / B) % B, l / (B * B))).cast<float>() * vs_;
      const Vector3f d = x - w_.anchor[i];
      float value;
      bool unsure;
      if (w_.is_signed(i)) {
        const float dn = w_.normal[i].dot(d);
        const float beside = std::max(0.0f, (d - dn * w_.normal[i]).norm() - foot);
        value = std::copysign(std::sqrt(dn * dn + beside * beside), dn);
        // Beside the edge of a surface rather than in front of or behind it: the sign is a guess.
        unsure = beside > std::abs(dn);
      } else {
        value = std::max(0.0f, d.norm() - 0.5f * vs_);
        unsure = true;
      }
      if (unsure) {
        value = std::abs(value);
        // Near the crease of a room's corner or the edge of a floor, the oriented surfaces around agree on the side
        // (beyond the truncation the side matters less than the time: free space decides there).
        const int side = value < trunc ? vote(nb, x) : 0;
        if (side != 0) {
          value *= static_cast<float>(side);
          unsure = false;
        }
      }
      b.q[static_cast<std::size_t>(l)] = map_.quantize(std::clamp(value, -trunc, trunc));
      if (unsure) b.unsure[static_cast<std::size_t>(l >> 6)] |= std::uint64_t{1} << (l & 63);
    }
  });
  std::deque<FireBlock>().swap(fire_);
  progress_(3, 1.0);
}

int Builder::vote(const Neighbourhood& nb, const Vector3f& x) const {
  const Vector3i v = (x / vs_).array().round().cast<int>();
  int front = 0, behind = 0;
  for (int dz = -kRadius; dz <= kRadius; ++dz)
    for (int dy = -kRadius; dy <= kRadius; ++dy)
      for (int dx = -kRadius; dx <= kRadius; ++dx) {
        const std::uint32_t j = nb.find(v + Vector3i(dx, dy, dz));
        if (j == kNone || !w_.is_signed(j)) continue;
        const float dn = w_.normal[j].dot(x - w_.anchor[j]);
        if (std::abs(dn) < 0.5f * vs_) continue;
        (dn > 0.0f ? front : behind) += 1;
        if (front > 0 && behind > 0) return 0;
      }
  return front >= 3 ? 1 : behind >= 3 ? -1 : 0;
}

}  // namespace tsdf_mcl::cloud_build
