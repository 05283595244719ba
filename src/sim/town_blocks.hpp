#pragma once
// What stands on a block of the built-in town (town_scene.cpp lays out the streets): buildings, a park or a parking
// lot, and the shapes the streets share with the blocks (cars, trees, lamp posts). Closed solids that overlap where
// they meet (building.hpp).
#include <cstdint>

#include "building.hpp"

namespace tsdf_mcl::sim {

constexpr float kKerb = 0.15f;     // m: blocks and sidewalks stand this high above the carriageway
constexpr float kSidewalk = 3.0f;  // m: buildings stand this far in from a block's edge

// One of a float range, drawn as a double (Rng's), so that a seed gives the same town everywhere.
inline float uniform(Rng& rng, float lo, float hi) { return static_cast<float>(rng.uniform(lo, hi)); }

// The contents of a block covering [0, w] x [0, h] in its own frame (the caller adds the block's slab): a design
// drawn from `design`, so blocks of one size and design look alike wherever they stand.
TriangleMesh block_contents(float w, float h, std::uint64_t design);

// A parked car (one in seven a van) standing on the floor at z, centred at (x, y), its length along x or y.
void add_car(TriangleMesh& mesh, float x, float y, float z, bool along_x, Rng& rng);
// A tree on the floor at z: a trunk and a crown of two crossed boxes from 2.6-3 m up to 5.4-7.4 m.
void add_tree(TriangleMesh& mesh, float x, float y, float z, Rng& rng);
// A bench 1.8 x 0.5 x 0.45 m on the floor at z, its length along x or y.
void add_bench(TriangleMesh& mesh, float x, float y, float z, bool along_x);
// A lamp post 7 m high on the floor at z, its arm reaching 1.8 m along (dx, dy) (a unit axis).
void add_lamp(TriangleMesh& mesh, float x, float y, float z, float dx, float dy);

}  // namespace tsdf_mcl::sim
