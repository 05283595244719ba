// The symmetric building: two identical wings either side of a lobby, one the other turned by 180 degrees,
// and one landmark that tells them apart.
//
// Plan (x east 0..40 m, y north 0..16 m, floor z = 0, ceiling z = 3):
//   a corridor (walls y 6.8 and 9.2) through the west wing (x 0..14), the lobby (x 14..26, the full width)
//   and the east wing (x 26..40); three rooms on either side of the corridor in each wing.
// Everything south of the corridor's centre line (y = 8) is built once and appended again turned by 180 deg
// about the vertical through (20, 8), so the whole building maps onto itself: the west wing's south rooms
// are the east wing's north rooms. The landmark, a display cabinet in the east wing's middle south room, is
// added last and has no image; its clear zone is kept free in both rooms.
#include <iterator>
#include <utility>

#include "building.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

constexpr Shell kShell{40.0f, 16.0f, 3.0f, 0.2f, 0.25f, 0.1f};
constexpr float kLength = kShell.length;
constexpr float kWall = 0.15f;
constexpr float kDoorHeight = 2.1f;
constexpr float kCorridorSouth = 6.8f;  // wall centre line; the north wall (9.2) is its image
constexpr float kWestWingEnd = 14.0f;   // the lobby is x 14..26
constexpr float kEastWingStart = kLength - kWestWingEnd;
const Eigen::Vector2f kCentre(kLength / 2, kShell.width / 2);

struct Room {
  float x0, x1;  // partition centre lines
  float door;    // centre of its door in the corridor wall
};

// The south rooms of both wings; the north rooms are their images. Room widths differ within a wing, so the
// north and south sides of a corridor look different, but the two wings do not.
constexpr Room kSouthRooms[] = {{0.0f, 5.0f, 3.8f},    {5.0f, 9.5f, 7.2f},    {9.5f, 14.0f, 11.0f},
                                {26.0f, 31.0f, 28.0f}, {31.0f, 35.5f, 33.8f}, {35.5f, 40.0f, 37.0f}};
constexpr std::size_t kLandmarkRoom = 4;
constexpr Rect kLandmark{32.6f, 2.6f, 33.8f, 3.2f};  // the display cabinet, 1.6 m high
constexpr float kLandmarkHeight = 1.6f;
constexpr float kDoorWidth = 1.0f;

void add_corridor_wall(TriangleMesh& half) {
  std::vector<Opening> doors;
  for (const Room& r : kSouthRooms) doors.push_back({r.door - kDoorWidth / 2, r.door + kDoorWidth / 2, kDoorHeight});
  // Each wing's piece reaches into the wall between wing and lobby.
  for (const auto& [from, to] :
       {std::pair{-kShell.sink, kWestWingEnd + kWall / 2}, {kEastWingStart - kWall / 2, kLength + kShell.sink}}) {
    std::vector<Opening> own;
    for (const Opening& d : doors) {
      if (d.from > from && d.to < to) own.push_back(d);
    }
    add_wall(half, true, kCorridorSouth, from, to, kWall, kShell.wall_bottom(), kShell.wall_top(), own);
  }
  for (float x : {5.0f, 9.5f, kWestWingEnd, kEastWingStart, 31.0f, 35.5f}) {
    add_wall(half, false, x, -kShell.sink, kCorridorSouth, kWall, kShell.wall_bottom(), kShell.wall_top(), {});
  }
}

// The lobby's southern half: two pillars, a reception counter, a bench; their images fill the north half.
void add_lobby(TriangleMesh& half) {
  const float h = 0.2f;  // pillar half width
  for (const Eigen::Vector2f& p : {Eigen::Vector2f(17.0f, 4.0f), Eigen::Vector2f(23.5f, 2.5f)}) {
    add_block(half, {p.x() - h, p.y() - h, p.x() + h, p.y() + h}, kShell.wall_bottom(), kShell.wall_top());
  }
  add_block(half, {18.6f, 5.2f, 21.4f, 5.8f}, -0.02f, 1.1f);   // reception counter
  add_block(half, {15.0f, 0.6f, 16.6f, 1.0f}, -0.02f, 0.45f);  // bench along the south wall
}

void add_corridor_furniture(TriangleMesh& half) {
  const float s = kCorridorSouth + kWall / 2;
  add_block(half, {5.6f, s + 0.05f, 7.0f, s + 0.45f}, -0.02f, 0.45f);   // bench in the west wing
  add_block(half, {0.05f, s + 0.1f, 0.55f, s + 0.9f}, -0.02f, 1.6f);    // vending machine at the west end
  add_block(half, {38.6f, s + 0.05f, 39.0f, s + 0.45f}, -0.02f, 1.2f);  // plant in the east wing
}

void furnish(TriangleMesh& half, std::size_t index, std::uint64_t seed) {
  const Room& room = kSouthRooms[index];
  const float w = kWall / 2 + 0.1f;  // furniture keeps 10 cm from the walls
  const Rect interior{room.x0 <= 0.0f ? 0.1f : room.x0 + w, 0.1f, room.x1 >= kLength ? kLength - 0.1f : room.x1 - w,
                      kCorridorSouth - w};
  Furnisher f(half, interior, 0.0f, Rng(mix_key(seed, index)));
  const float clear = kDoorWidth / 2 + 0.6f;
  f.keep_clear({room.door - clear, interior.y1 - 1.6f, room.door + clear, interior.y1 + 1.0f});
  // Both the landmark's room and its image keep the landmark's place free.
  if (index == kLandmarkRoom) f.keep_clear(kLandmark.grown(1.0f));
  using F = Furnisher;
  f.line_walls({F::kDesk, F::kDesk, F::kTallCabinet, F::kSideboard, F::kShelf, F::kWhiteboard});
}

}  // namespace

BuiltInScene symmetric_scene(std::uint64_t seed) {
  TriangleMesh half;
  add_corridor_wall(half);
  add_lobby(half);
  add_corridor_furniture(half);
  for (std::size_t i = 0; i < std::size(kSouthRooms); ++i) furnish(half, i, seed);

  BuiltInScene scene;
  add_shell(scene.mesh, kShell);
  scene.mesh.append(half);
  append_half_turn(scene.mesh, half, kCentre);

  Landmark landmark;
  landmark.name = "display cabinet";
  landmark.first_triangle = scene.mesh.triangles.size();
  add_block(scene.mesh, kLandmark, -0.02f, kLandmarkHeight);
  landmark.triangle_count = scene.mesh.triangles.size() - landmark.first_triangle;
  landmark.box = Eigen::AlignedBox3f(Eigen::Vector3f(kLandmark.x0, kLandmark.y0, 0.0f),
                                     Eigen::Vector3f(kLandmark.x1, kLandmark.y1, kLandmarkHeight));
  // Between the cabinet and the room's door: the cabinet fills the view.
  landmark.viewpoint = Eigen::Vector2d(kSouthRooms[kLandmarkRoom].door, 4.6);
  scene.landmark = landmark;

  // The half turn about the vertical through the centre: (x, y, z) -> (40 - x, 16 - y, z).
  Pose mirror = Pose::Identity();
  mirror.linear() = Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();
  mirror.translation() = Eigen::Vector3d(kLength, kShell.width, 0.0);
  scene.mirror = mirror;
  return scene;
}

}  // namespace tsdf_mcl::sim
