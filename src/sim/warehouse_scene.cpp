// The built-in warehouse: a 40 x 25 m hall, 7 m high, with rows of pallet racks.
//
// Plan (x east 0..40 m, y north 0..25 m, floor z = 0, roof slab from z = 7):
//   the loading dock along the south wall: four closed dock doors (roller doors in recesses), bollards beside
//   them, a staging area (y 0..8) with three columns, a workbench and pallets on the floor;
//   fourteen rack rows (one along each side wall, six back-to-back pairs) running north from y = 8 to 22,
//   3.2 m aisles between them, a 3 m cross aisle along the north wall; roof girders over the columns.
// A rack is uprights braced in zig-zag, beam pairs at four levels (the lowest 0.1-0.2 m above the floor, so
// nothing drives into a rack) and pallets on the beams, some loaded: the LiDAR sees through the racks where
// slots are empty and between the loads. --scene_seed decides which slots hold pallets, their loads and the
// staging area's pallets.
#include <array>
#include <cmath>

#include "building.hpp"
#include "shapes.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector2f;

constexpr Shell kShell{40.0f, 25.0f, 7.0f, 0.3f, 0.3f, 0.1f};

// Dock doors in the south wall: 3 m wide, 3.6 m high, the roller door 0.22 m behind the inner face.
constexpr float kDockDoorWidth = 3.0f;
constexpr float kDockDoorHeight = 3.6f;
constexpr std::array<float, 4> kDockDoors = {8.0f, 16.0f, 24.0f, 32.0f};  // centres

// Racks: rows along y.
constexpr float kRackSouth = 8.0f;
constexpr float kBay = 2.8f;  // upright spacing along the row
constexpr int kBays = 5;      // rows end at y = 8 + 5 * 2.8 = 22
constexpr float kRackDepth = 1.1f;
constexpr float kFlue = 0.2f;  // between back-to-back rows
constexpr float kAisle = 3.2f;
constexpr float kPost = 0.1f;  // upright profile
constexpr float kRackHeight = 6.0f;
constexpr std::array<float, 4> kBeamTops = {0.2f, 1.8f, 3.4f, 5.0f};
constexpr float kBeamHeight = 0.1f;
constexpr float kBeamDepth = 0.05f;
constexpr int kSlotsPerBay = 3;
constexpr float kPalletWidth = 0.8f;  // along the row
constexpr float kPalletDepth = 1.2f;  // across, overhanging the rack 5 cm front and back
constexpr float kPalletHeight = 0.144f;
constexpr float kMaxLoad = 1.3f;  // leaves room under the next beam

const std::array<Vector2f, 3> kColumns = {Vector2f(10.0f, 4.5f), Vector2f(20.0f, 4.5f), Vector2f(30.0f, 4.5f)};

// The low-x side of each single rack row.
std::vector<float> rack_rows() {
  std::vector<float> rows{0.5f};  // along the west wall
  const float first_pair = 0.5f + kRackDepth + kAisle;
  for (int pair = 0; pair < 6; ++pair) {
    const float x = first_pair + static_cast<float>(pair) * (2.0f * kRackDepth + kFlue + kAisle);
    rows.push_back(x);
    rows.push_back(x + kRackDepth + kFlue);
  }
  rows.push_back(rows.back() + kRackDepth + kAisle);  // along the east wall
  return rows;
}

// One upright frame: a front and a back post, braced in zig-zag.
void add_upright_frame(TriangleMesh& mesh, float x0, float y) {
  const float h = kPost / 2;
  add_block(mesh, {x0, y - h, x0 + kPost, y + h}, -0.02f, kRackHeight);
  const float x1 = x0 + kRackDepth;
  add_block(mesh, {x1 - kPost, y - h, x1, y + h}, -0.02f, kRackHeight);
  // Braces reach 3 cm into the posts; a brace is 5 cm thick, 4 cm wide.
  const float a = x0 + kPost - 0.03f, b = x1 - kPost + 0.03f, t = 0.05f;
  const float rise = 1.3f;
  for (int k = 0; k < 4; ++k) {
    const float z = 0.3f + static_cast<float>(k) * rise;
    if (k % 2 == 0) {
      add_prism_xz(mesh, {Vector2f(a, z), Vector2f(b, z + rise), Vector2f(b, z + rise + t), Vector2f(a, z + t)},
                   y - 0.02f, y + 0.02f);
    } else {
      add_prism_xz(mesh, {Vector2f(a, z + rise), Vector2f(b, z), Vector2f(b, z + t), Vector2f(a, z + rise + t)},
                   y - 0.02f, y + 0.02f);
    }
  }
}

// A pallet on the beams (or the floor) at `bottom`, loaded with probability 0.85.
void add_pallet(TriangleMesh& mesh, const Rect& footprint, float bottom, Rng& rng) {
  const float top = bottom + kPalletHeight;
  add_block(mesh, footprint, bottom - 0.01f, top);
  if (rng.chance(0.15)) return;
  const float load = static_cast<float>(rng.uniform(0.4, kMaxLoad));
  const float inset = static_cast<float>(rng.uniform(0.01, 0.06));
  add_block(mesh, footprint.grown(-inset), top - 0.01f, top + load);
}

void add_rack_row(TriangleMesh& mesh, float x0, Rng& rng) {
  const float x1 = x0 + kRackDepth;
  for (int k = 0; k <= kBays; ++k) add_upright_frame(mesh, x0, kRackSouth + static_cast<float>(k) * kBay);
  const float gap = (kBay - kPost - kSlotsPerBay * kPalletWidth) / (kSlotsPerBay + 1);
  for (int bay = 0; bay < kBays; ++bay) {
    const float y0 = kRackSouth + static_cast<float>(bay) * kBay + kPost / 2;  // clear span between posts
    const float y1 = y0 + kBay - kPost;
    for (const float top : kBeamTops) {
      // Beams run 2 cm into the posts at both ends.
      add_block(mesh, {x0, y0 - 0.02f, x0 + kBeamDepth, y1 + 0.02f}, top - kBeamHeight, top);
      add_block(mesh, {x1 - kBeamDepth, y0 - 0.02f, x1, y1 + 0.02f}, top - kBeamHeight, top);
      for (int slot = 0; slot < kSlotsPerBay; ++slot) {
        if (!rng.chance(0.7)) continue;
        const float s = y0 + gap + static_cast<float>(slot) * (kPalletWidth + gap);
        const float overhang = (kPalletDepth - kRackDepth) / 2;
        add_pallet(mesh, {x0 - overhang, s, x1 + overhang, s + kPalletWidth}, top, rng);
      }
    }
  }
}

void add_dock(TriangleMesh& mesh) {
  for (const float c : kDockDoors) {
    const float x0 = c - kDockDoorWidth / 2, x1 = c + kDockDoorWidth / 2;
    // The roller door fills the opening's outer part and reaches into the wall around it.
    add_block(mesh, {x0 - 0.05f, -kShell.outer_wall, x1 + 0.05f, -0.22f}, kShell.wall_bottom(),
              kDockDoorHeight + 0.05f);
    for (const float x : {x0 - 0.35f, x1 + 0.2f})
      add_block(mesh, {x, 0.3f, x + 0.15f, 0.45f}, -0.02f, 1.1f);  // bollards
  }
}

void add_structure(TriangleMesh& mesh) {
  const float h = 0.2f;
  for (const Vector2f& c : kColumns) {
    add_block(mesh, {c.x() - h, c.y() - h, c.x() + h, c.y() + h}, kShell.wall_bottom(), kShell.wall_top());
    // A roof girder over each column, wall to wall, and a pilaster where it meets the north wall.
    add_block(mesh, {c.x() - 0.15f, -0.1f, c.x() + 0.15f, kShell.width + 0.1f}, kShell.ceiling - 0.6f,
              kShell.wall_top());
    add_block(mesh, {c.x() - h, kShell.width - 0.3f, c.x() + h, kShell.width + 0.1f}, kShell.wall_bottom(),
              kShell.wall_top());
  }
  add_block(mesh, {0.1f, 1.5f, 0.8f, 3.5f}, -0.02f, 0.9f);  // workbench by the west wall
}

// Pallet stacks waiting in the staging area: clear of the dock doors' approach, the columns and the racks.
void add_staging_pallets(TriangleMesh& mesh, Rng& rng) {
  std::vector<Rect> placed;
  for (const Vector2f& c : kColumns) placed.push_back(Rect{c.x(), c.y(), c.x(), c.y()}.grown(1.0f));
  for (const float d : kDockDoors)
    placed.push_back({d - kDockDoorWidth / 2 - 0.5f, 0.0f, d + kDockDoorWidth / 2 + 0.5f, 3.0f});
  placed.push_back({0.0f, 1.0f, 1.5f, 4.0f});  // the workbench
  const int count = 4 + static_cast<int>(rng.below(5));
  for (int k = 0, attempts = 0; k < count && attempts < 200; ++attempts) {
    const bool turned = rng.chance(0.5);
    const float w = turned ? kPalletDepth : kPalletWidth, d = turned ? kPalletWidth : kPalletDepth;
    const float x = static_cast<float>(rng.uniform(0.5, kShell.length - 0.5 - w));
    const float y = static_cast<float>(rng.uniform(0.5, kRackSouth - 1.8 - d));
    const Rect r{x, y, x + w, y + d};
    bool free = true;
    for (const Rect& o : placed) free = free && !r.overlaps(o.grown(1.0f));
    if (!free) continue;
    placed.push_back(r);
    add_pallet(mesh, r, 0.0f, rng);
    ++k;
  }
}

}  // namespace

TriangleMesh warehouse_scene(std::uint64_t seed) {
  TriangleMesh mesh;
  std::vector<Opening> doors;
  for (const float c : kDockDoors) doors.push_back({c - kDockDoorWidth / 2, c + kDockDoorWidth / 2, kDockDoorHeight});
  add_shell(mesh, kShell, doors);
  add_dock(mesh);
  add_structure(mesh);
  const std::vector<float> rows = rack_rows();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    Rng rng(mix_key(seed, i));
    add_rack_row(mesh, rows[i], rng);
  }
  Rng staging_rng(mix_key(seed, rows.size()));
  add_staging_pallets(mesh, staging_rng);
  return mesh;
}

}  // namespace tsdf_mcl::sim
