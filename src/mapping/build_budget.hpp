#pragma once
// The working-memory budget of map building. Builders charge what they allocate as they go (the coarse box, blocks
// near surfaces, per-block scratch), before allocating it, so that a small hostile input (one far vertex, a chunk
// far from the others) ends in one clear error instead of gigabytes. Work is proportional to what is charged, so the
// budget bounds building time as well.
#include <atomic>
#include <cstdint>
#include <string>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {

class BuildBudget {
 public:
  explicit BuildBudget(std::uint64_t max_bytes) : max_bytes_(max_bytes) {}

  // Adds `bytes`; throws Error naming the budget, what exceeded it and how to raise it. Threads may share a budget.
  void charge(std::uint64_t bytes, const char* what) {
    const std::uint64_t before = used_.fetch_add(bytes, std::memory_order_relaxed);
    if (bytes <= max_bytes_ && before <= max_bytes_ - bytes) return;
    throw Error("building the map needs more than its memory budget of " + std::to_string(max_bytes_ >> 20) + " MiB (" +
                what +
                "); raise it with build-map --max_memory MIB, or use a larger --voxel or a "
                "smaller area");
  }
  // Gives back what a freed buffer had charged (a buffer replaced by a larger one).
  void release(std::uint64_t bytes) { used_.fetch_sub(bytes, std::memory_order_relaxed); }

 private:
  std::uint64_t max_bytes_;
  std::atomic<std::uint64_t> used_{0};
};

}  // namespace tsdf_mcl
