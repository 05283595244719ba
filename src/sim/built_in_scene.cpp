#include <cstdio>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

constexpr double kTownSize = 120.0;  // m, the town's default extent

}  // namespace

BuiltInScene built_in_scene(const std::string& name, std::uint64_t seed, double size_m) {
  if (size_m != 0.0 && name != "town") throw Error("a scene size applies to the town only, not to '" + name + "'");
  BuiltInScene scene;
  if (name == "office") {
    scene.mesh = office_scene(seed);
  } else if (name == "symmetric") {
    scene = symmetric_scene(seed);
  } else if (name == "warehouse") {
    scene.mesh = warehouse_scene(seed);
  } else if (name == "two-storey") {
    scene = two_storey_scene(seed);
  } else if (name == "town") {
    const double size = size_m != 0.0 ? size_m : kTownSize;
    scene = town_scene(seed, size);
    char description[96];
    std::snprintf(description, sizeof(description), "built-in town, %g x %g m (scene seed %llu)", size, size,
                  static_cast<unsigned long long>(seed));
    scene.description = description;
    return scene;
  } else {
    throw Error("no built-in scene '" + name + "' (office, symmetric, warehouse, two-storey, town)");
  }
  scene.description = "built-in " + name + " (scene seed " + std::to_string(seed) + ")";
  return scene;
}

}  // namespace tsdf_mcl::sim
