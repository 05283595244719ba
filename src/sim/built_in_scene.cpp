#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

BuiltInScene built_in_scene(const std::string& name, std::uint64_t seed) {
  BuiltInScene scene;
  if (name == "office") {
    scene.mesh = office_scene(seed);
  } else if (name == "symmetric") {
    scene = symmetric_scene(seed);
  } else if (name == "warehouse") {
    scene.mesh = warehouse_scene(seed);
  } else if (name == "two-storey") {
    scene = two_storey_scene(seed);
  } else {
    throw Error("no built-in scene '" + name + "' (office, symmetric, warehouse, two-storey)");
  }
  scene.description = "built-in " + name + " (scene seed " + std::to_string(seed) + ")";
  return scene;
}

}  // namespace tsdf_mcl::sim
