#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl::cli {
namespace {

// The double nearest to a float's shortest decimal form, so JSON shows 0.05 rather than 0.05000000074505806.
double tidy(float value) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof(text) - 1, value).ptr;
  *end = '\0';
  return std::strtod(text, nullptr);
}

nlohmann::json tidy(const Eigen::Vector3f& v) { return {tidy(v.x()), tidy(v.y()), tidy(v.z())}; }

}  // namespace

int run_info(int argc, char** argv) {
  Options o("info", "tsdf-mcl info MAP [--json]", {{"json", "", "", "print one JSON object instead of readable lines"}},
            argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(1, "one map file: tsdf-mcl info MAP");
  const std::string file = o.positional().front();
  const TsdfMap map = load_map(file);
  const TsdfMap::Stats s = map.stats();
  const Eigen::Vector3f lo = map.world_min(), hi = map.world_max(), size = hi - lo;
  const Eigen::Vector3i& dims = map.dims_blocks();
  const double voxel = tidy(map.voxel_size());
  const double voxel_volume = voxel * voxel * voxel;
  const double known_m3 = static_cast<double>(s.known_voxels) * voxel_volume;
  const double free_m3 = static_cast<double>(s.free_voxels) * voxel_volume;
  const double mib = static_cast<double>(s.memory_bytes) / (1024.0 * 1024.0);

  if (o.flag("json")) {
    const nlohmann::json j = {
        {"file", file},
        {"voxel_size", tidy(map.voxel_size())},
        {"truncation", tidy(map.truncation())},
        {"block_size", TsdfMap::kBlockSize},
        {"world_min", tidy(lo)},
        {"world_max", tidy(hi)},
        {"size", tidy(size)},
        {"min_block", {map.min_block().x(), map.min_block().y(), map.min_block().z()}},
        {"dims_blocks", {dims.x(), dims.y(), dims.z()}},
        {"coarse_cells", map.coarse_index().size()},
        {"allocated_blocks", s.allocated_blocks},
        {"free_blocks", s.free_blocks},
        {"memory_bytes", s.memory_bytes},
        {"known_voxels", s.known_voxels},
        {"free_voxels", s.free_voxels},
        {"known_volume_m3", known_m3},
        {"free_volume_m3", free_m3},
    };
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("map:          %s\n", file.c_str());
  std::printf("resolution:   %.3f m voxels, blocks of %d^3 voxels\n", static_cast<double>(map.voxel_size()),
              TsdfMap::kBlockSize);
  std::printf("truncation:   %.3f m (distances are stored within this band around surfaces)\n",
              static_cast<double>(map.truncation()));
  std::printf("extent:       (%.2f, %.2f, %.2f) .. (%.2f, %.2f, %.2f) m, size %.2f x %.2f x %.2f m\n",
              static_cast<double>(lo.x()), static_cast<double>(lo.y()), static_cast<double>(lo.z()),
              static_cast<double>(hi.x()), static_cast<double>(hi.y()), static_cast<double>(hi.z()),
              static_cast<double>(size.x()), static_cast<double>(size.y()), static_cast<double>(size.z()));
  std::printf("coarse index: %d x %d x %d blocks (%zu cells: one per block of the extent, pointing to its voxels)\n",
              dims.x(), dims.y(), dims.z(), map.coarse_index().size());
  std::printf(
      "blocks:       %zu allocated (voxels stored: near surfaces), %zu free (wholly free space, one "
      "flag, no voxels)\n",
      s.allocated_blocks, s.free_blocks);
  std::printf("memory:       %.2f MiB (coarse index + block pool)\n", mib);
  std::printf("known volume: %.1f m^3 (observed: surfaces and free space; the rest is unknown)\n", known_m3);
  std::printf("free volume:  %.1f m^3 (observed empty: where particles of a global search may start)\n", free_m3);
  return 0;
}

}  // namespace tsdf_mcl::cli
