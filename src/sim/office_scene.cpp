// The built-in office floor, from closed solids that overlap where they meet (sim/building.hpp).
//
// Plan (x east 0..50 m, y north 0..20 m, floor z = 0, ceiling z = 3):
//   corridor y 9..11.5 along the whole floor; at x 32..36 it climbs a 7 deg ramp to the east wing (x > 36),
//   whose floor is 0.5 m higher. South of the corridor: a hall (x 0..14) with a stage reached by an 8.5 deg
//   ramp and a wide opening to the corridor, three small offices, a lab, three offices in the east wing.
//   North: a kitchen, three small offices, a conference room with two doors, an open office with a storage
//   room behind it (reached only through the open office), three offices in the east wing.
#include <cmath>
#include <utility>

#include "building.hpp"
#include "shapes.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector2f;
using Eigen::Vector3f;

constexpr float kLength = 50.0f;
constexpr float kWidth = 20.0f;
constexpr float kCeiling = 3.0f;
constexpr float kSlab = 0.2f;  // floor and ceiling slab thickness
constexpr float kOuterWall = 0.25f;
constexpr float kWall = 0.15f;  // interior walls
constexpr float kSink = 0.1f;   // how far walls and raised floors reach into the slabs
constexpr float kDoorHeight = 2.1f;
constexpr float kCorridorSouth = 9.0f;  // wall centre lines
constexpr float kCorridorNorth = 11.5f;
constexpr float kWingX = 36.0f;  // the east wing's floor is raised
constexpr float kWingHeight = 0.5f;
constexpr float kRampStart = 32.0f;  // corridor ramp x 32..36
constexpr float kStageX = 5.5f;      // hall stage x 0..5.5, y 0..4.2
constexpr float kStageY = 4.2f;
constexpr float kStageHeight = 0.45f;
constexpr float kStageRampEnd = 8.5f;  // stage ramp x 5.5..8.5, y 1..3
constexpr float kStageRampY0 = 1.0f;
constexpr float kStageRampY1 = 3.0f;

float floor_at(float x) { return x >= kWingX ? kWingHeight : 0.0f; }

// Interior walls stand from inside the floor slab to inside the ceiling slab.
void add_storey_wall(TriangleMesh& mesh, bool along_x, float line, float from, float to,
                     std::vector<Opening> openings) {
  add_wall(mesh, along_x, line, from, to, kWall, -kSink, kCeiling + kSink, std::move(openings));
}

Opening door(float centre, float width) {
  return {centre - width / 2, centre + width / 2, floor_at(centre) + kDoorHeight};
}

enum class RoomKind { hall, office, lab, kitchen, conference, open_office, storage };

struct Room {
  float x0, x1;  // partition centre lines
  bool south;
  RoomKind kind;
  std::vector<float> doors;  // centres on the corridor wall
  float door_width = 1.0f;
};

void add_levels(TriangleMesh& mesh) {
  // East wing floor, and the corridor ramp up to it (its flat tip overlaps the wing to avoid a shared face).
  add_block(mesh, {kWingX, -kSink, kLength + kSink, kWidth + kSink}, -kSink, kWingHeight);
  add_prism_xz(mesh,
               {Vector2f(kRampStart, -kSink), Vector2f(kWingX + 0.2f, -kSink), Vector2f(kWingX + 0.2f, kWingHeight),
                Vector2f(kWingX, kWingHeight), Vector2f(kRampStart, 0.0f)},
               kCorridorSouth - kWall / 2, kCorridorNorth + kWall / 2);
  // Hall stage and its ramp, rising towards -x.
  add_block(mesh, {-kSink, -kSink, kStageX, kStageY}, -kSink, kStageHeight);
  add_prism_xz(mesh,
               {Vector2f(kStageX - 0.2f, -kSink), Vector2f(kStageRampEnd, -kSink), Vector2f(kStageRampEnd, 0.0f),
                Vector2f(kStageX, kStageHeight), Vector2f(kStageX - 0.2f, kStageHeight)},
               kStageRampY0, kStageRampY1);
}

std::vector<Room> rooms() {
  using K = RoomKind;
  return {
      {0, 14, true, K::hall, {2.5f}},
      {14, 18, true, K::office, {16.4f}},
      {18, 22, true, K::office, {20.4f}},
      {22, 26, true, K::office, {24.4f}},
      {26, 36, true, K::lab, {28.0f}, 1.4f},
      {36, 42, true, K::office, {38.0f}},
      {42, 46, true, K::office, {44.4f}},
      {46, 50, true, K::office, {48.4f}},
      {0, 5, false, K::kitchen, {3.6f}},
      {5, 9, false, K::office, {7.6f}},
      {9, 13, false, K::office, {11.6f}},
      {13, 17, false, K::office, {15.6f}},
      {17, 25, false, K::conference, {18.6f, 23.4f}},
      {25, 32, false, K::open_office, {30.5f}, 1.2f},
      {32, 36, false, K::storage, {}},
      {36, 40, false, K::office, {38.4f}},
      {40, 44, false, K::office, {42.4f}},
      {44, 50, false, K::office, {45.0f}},
  };
}

// The hall's wide opening to the corridor, and the door from the open office into the storage room.
constexpr float kHallOpening0 = 9.5f, kHallOpening1 = 13.5f, kHallOpeningTop = 2.5f;
constexpr float kStorageDoorY = 18.5f;

void add_walls(TriangleMesh& mesh, const std::vector<Room>& all) {
  std::vector<Opening> south, north;
  for (const Room& r : all) {
    for (float d : r.doors) (r.south ? south : north).push_back(door(d, r.door_width));
  }
  south.push_back({kHallOpening0, kHallOpening1, kHallOpeningTop});
  add_storey_wall(mesh, true, kCorridorSouth, 0.0f, kLength, south);
  add_storey_wall(mesh, true, kCorridorNorth, 0.0f, kLength, north);
  for (const Room& r : all) {
    if (r.x0 <= 0.0f) continue;
    const float y0 = r.south ? -kSink : kCorridorNorth;
    const float y1 = r.south ? kCorridorSouth : kWidth + kSink;
    std::vector<Opening> openings;
    if (r.kind == RoomKind::storage) openings.push_back({kStorageDoorY - 0.5f, kStorageDoorY + 0.5f, kDoorHeight});
    add_storey_wall(mesh, false, r.x0, y0, y1, openings);
  }
}

void add_pillars(TriangleMesh& mesh) {
  const float h = 0.2f;  // half width
  auto pillar = [&](float x, float y) { add_block(mesh, {x - h, y - h, x + h, y + h}, -kSink, kCeiling + kSink); };
  for (float x : {14.0f, 22.0f, 26.0f}) pillar(x, kCorridorSouth);  // structural columns in the corridor walls
  for (float x : {9.0f, 17.0f, 25.0f, 32.0f}) pillar(x, kCorridorNorth);
  pillar(3.5f, 6.6f);  // free-standing in the hall, the lab and the conference room
  pillar(8.0f, 6.6f);
  pillar(12.0f, 4.6f);
  pillar(31.0f, 4.5f);
  pillar(21.0f, 15.8f);
}

void add_corridor_furniture(TriangleMesh& mesh) {
  const float s = kCorridorSouth + kWall / 2, n = kCorridorNorth - kWall / 2;
  add_block(mesh, {19.3f, n - 0.6f, 19.9f, n}, -0.02f, 1.0f);                             // printer
  add_block(mesh, {28.8f, s, 30.4f, s + 0.4f}, -0.02f, 0.45f);                            // bench
  add_block(mesh, {43.6f, n - 0.4f, 44.0f, n}, kWingHeight - 0.02f, kWingHeight + 1.2f);  // plant
  add_block(mesh, {0.0f, s + 0.3f, 0.5f, s + 1.1f}, -0.02f, 1.6f);  // vending machine at the west end
}

// The two-storey office's staircase: a straight flight against the lab's south wall rising along +x from the
// lower floor to the upper one (20 steps of 0.28 x 0.16 m), under an opening in the slab between the storeys.
constexpr float kStoreyRise = kCeiling + kSlab;  // the upper storey's floor
constexpr int kSteps = 20;
constexpr Rect kFlight{28.0f, 0.0f, 28.0f + 0.28f * kSteps, 1.1f};
constexpr Rect kOpening{29.6f, 0.0f, kFlight.x1, 1.2f};  // in the slab; the flight's top step is the floor above
constexpr float kParapet = 0.1f, kParapetHeight = 1.0f;  // the upper storey's railing along the opening

void furnish(TriangleMesh& mesh, const Room& room, std::size_t index, std::uint64_t seed, bool stairwell) {
  const float half = kWall / 2;
  Rect interior{room.x0 <= 0.0f ? 0.0f : room.x0 + half, room.south ? 0.0f : kCorridorNorth + half,
                room.x1 >= kLength ? kLength : room.x1 - half, room.south ? kCorridorSouth - half : kWidth};
  // Keep the pillar positions clear (pillars stick 0.125 m out of the walls).
  interior = interior.grown(-0.13f);
  const float floor = floor_at(room.x0 + 0.01f);
  Furnisher f(mesh, interior, floor, Rng(mix_key(seed, index)));
  const float door_wall = room.south ? interior.y1 : interior.y0;
  for (float d : room.doors) {
    const float w = room.door_width / 2 + 0.6f;
    f.keep_clear(room.south ? Rect{d - w, door_wall - 1.6f, d + w, door_wall + 1.0f}
                            : Rect{d - w, door_wall - 1.0f, d + w, door_wall + 1.6f});
  }
  using F = Furnisher;
  switch (room.kind) {
    case RoomKind::hall: {
      // Stage, its ramp and approach, the corridor opening and the free-standing pillars stay clear.
      f.keep_clear({-1.0f, -1.0f, kStageX + 0.3f, kStageY + 0.3f});
      f.keep_clear({kStageX, kStageRampY0 - 0.8f, kStageRampEnd + 2.0f, kStageRampY1 + 0.8f});
      f.keep_clear({kHallOpening0 - 0.6f, kCorridorSouth - 2.2f, kHallOpening1 + 0.6f, kCorridorSouth + 1.0f});
      for (const Rect& p :
           {Rect{3.3f, 6.4f, 3.7f, 6.8f}, Rect{7.8f, 6.4f, 8.2f, 6.8f}, Rect{11.8f, 4.4f, 12.2f, 4.8f}}) {
        f.keep_clear(p.grown(0.8f));
      }
      f.place_centre({5.2f, 5.6f, 6.6f, 7.6f}, 0.74f, true);
      f.line_walls({F::kSideboard, F::kShelf, F::kWhiteboard});
      add_block(mesh, {0.3f, 3.0f, 0.9f, 3.5f}, kStageHeight - 0.02f, kStageHeight + 1.1f);  // lectern
      break;
    }
    case RoomKind::office:
      f.line_walls({F::kDesk, F::kDesk, F::kTallCabinet, F::kSideboard, F::kShelf, F::kWhiteboard});
      break;
    case RoomKind::lab:
      f.keep_clear({30.3f, 4.0f, 31.7f, 5.0f});
      if (stairwell) f.keep_clear({kFlight.x0 - 1.0f, -1.0f, kFlight.x1 + 1.2f, kOpening.y1 + kParapet + 0.9f});
      f.place_centre({27.5f, 3.0f, 29.5f, 3.9f}, 0.9f, false);
      f.place_centre({32.5f, 4.0f, 34.5f, 4.9f}, 0.9f, false);
      f.line_walls({F::kCounter, F::kTallCabinet, F::kShelf});
      break;
    case RoomKind::kitchen:
      f.place_centre({1.6f, 15.3f, 2.8f, 16.1f}, 0.74f, true);
      f.line_walls({F::kCounter, F::kTallCabinet});
      break;
    case RoomKind::conference:
      f.keep_clear({20.7f, 15.5f, 21.3f, 16.1f});
      f.place_centre({18.3f, 13.4f, 19.7f, 18.3f}, 0.74f, true);
      f.place_centre({22.5f, 14.0f, 23.7f, 17.0f}, 0.74f, true);
      f.line_walls({F::kSideboard, F::kWhiteboard});
      break;
    case RoomKind::open_office:
      f.keep_clear({31.0f, kStorageDoorY - 1.2f, 32.0f, kStorageDoorY + 1.2f});
      f.place_centre({26.3f, 14.0f, 27.9f, 15.6f}, 0.74f, true);
      f.place_centre({29.1f, 15.8f, 30.7f, 17.4f}, 0.74f, true);
      f.line_walls({F::kDesk, F::kDesk, F::kSideboard, F::kTallCabinet});
      break;
    case RoomKind::storage:
      f.keep_clear({32.0f, kStorageDoorY - 1.2f, 33.6f, kStorageDoorY + 1.2f});
      f.line_walls({F::kShelf, F::kShelf, F::kTallCabinet});
      break;
  }
}

// One storey of the office: its shell (with the slabs asked for), floor levels, walls, pillars and furniture.
TriangleMesh office_storey(std::uint64_t seed, bool floor_slab, bool ceiling_slab, bool stairwell) {
  TriangleMesh mesh;
  Shell shell{kLength, kWidth, kCeiling, kSlab, kOuterWall, kSink};
  shell.floor_slab = floor_slab;
  shell.ceiling_slab = ceiling_slab;
  add_shell(mesh, shell);
  add_levels(mesh);
  const std::vector<Room> all = rooms();
  add_walls(mesh, all);
  add_pillars(mesh);
  add_corridor_furniture(mesh);
  for (std::size_t i = 0; i < all.size(); ++i) furnish(mesh, all[i], i, seed, stairwell);
  return mesh;
}

// The slab between the storeys (the lower one's ceiling, the upper one's floor) round the opening; the pieces
// overlap rather than share faces.
void add_slab_with_opening(TriangleMesh& mesh) {
  const float m = kOuterWall, z0 = kCeiling, z1 = kStoreyRise;
  add_block(mesh, {-m, -m, kOpening.x0, kWidth + m}, z0, z1);
  add_block(mesh, {kOpening.x1, -m, kLength + m, kWidth + m}, z0, z1);
  add_block(mesh, {kOpening.x0 - 0.05f, kOpening.y1, kOpening.x1 + 0.05f, kWidth + m}, z0, z1);
  add_block(mesh, {kOpening.x0 - 0.05f, -m, kOpening.x1 + 0.05f, kOpening.y0}, z0, z1);
}

}  // namespace

TriangleMesh office_scene(std::uint64_t seed) { return office_storey(seed, true, true, false); }

BuiltInScene two_storey_scene(std::uint64_t seed) {
  BuiltInScene scene;
  scene.mesh = office_storey(seed, true, false, true);
  TriangleMesh upper = office_storey(seed, false, true, true);
  for (Vector3f& v : upper.vertices) v.z() += kStoreyRise;
  scene.mesh.append(upper);
  add_slab_with_opening(scene.mesh);
  scene.storey_floors = {0.0f, kStoreyRise};

  // The staircase and the railing along its opening: what a scan sees differently on the two storeys.
  Landmark landmark;
  landmark.name = "staircase";
  landmark.first_triangle = scene.mesh.triangles.size();
  for (int k = 0; k < kSteps; ++k) {  // solid steps: nothing under the flight
    const float x = kFlight.x0 + 0.28f * static_cast<float>(k);
    // Each step reaches 2 cm into the next and under the floor: overlapping solids, no shared faces.
    add_block(scene.mesh, {x, kFlight.y0 - 0.05f, x + 0.3f, kFlight.y1}, -0.02f,
              kStoreyRise / kSteps * static_cast<float>(k + 1));
  }
  const float rail0 = kStoreyRise - 0.02f, rail1 = kStoreyRise + kParapetHeight;
  add_block(scene.mesh, {kOpening.x0 - kParapet, kOpening.y1, kOpening.x1, kOpening.y1 + kParapet}, rail0, rail1);
  add_block(scene.mesh, {kOpening.x0 - kParapet, kOpening.y0 - 0.05f, kOpening.x0, kOpening.y1 + 0.05f}, rail0, rail1);
  landmark.triangle_count = scene.mesh.triangles.size() - landmark.first_triangle;
  landmark.box =
      Eigen::AlignedBox3f(Vector3f(kFlight.x0, kFlight.y0, 0.0f), Vector3f(kOpening.x1, kOpening.y1 + kParapet, rail1));
  // In the lab, in front of the flight: its steps (below) or the railing and the hole (above) fill the view.
  landmark.viewpoint = Eigen::Vector2d(31.0, 2.8);
  scene.landmark = landmark;
  return scene;
}

}  // namespace tsdf_mcl::sim
