#pragma once
// Pieces of the built-in buildings: rectangles on the floor plan, blocks, walls with openings, the outer
// shell, furniture along room walls. Everything is a closed solid with outward normals (sim/shapes.hpp), and
// solids overlap where they meet instead of sharing faces: a face shared by two solids points both ways at
// once, which makes the sign of a mesh's distance field ambiguous there.
#include <Eigen/Core>
#include <vector>

#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/io/mesh.hpp"

namespace tsdf_mcl::sim {

// An axis-aligned rectangle of the floor plan (m).
struct Rect {
  float x0, y0, x1, y1;
  Rect grown(float m) const { return {x0 - m, y0 - m, x1 + m, y1 + m}; }
  bool overlaps(const Rect& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
  bool contains(const Rect& o) const { return o.x0 >= x0 && o.x1 <= x1 && o.y0 >= y0 && o.y1 <= y1; }
};

// The box over r from height z0 to z1.
void add_block(TriangleMesh& mesh, const Rect& r, float z0, float z1);

struct Opening {
  float from, to;  // along the wall
  float top;       // height of the lintel's underside
};

// A wall between `from` and `to` along one axis, centred on `line` across it, from z0 to z1, with openings;
// each opening leaves a lintel from its top up to z1.
void add_wall(TriangleMesh& mesh, bool along_x, float line, float from, float to, float thickness, float z0, float z1,
              std::vector<Opening> openings);

// Floor and ceiling slabs and four outer walls around the interior [0, length] x [0, width] (floor z = 0);
// walls reach `sink` into the slabs.
struct Shell {
  float length, width, ceiling;
  float slab, outer_wall, sink;
  // A storey of a taller building leaves out the slab it shares with the storey below or above.
  bool floor_slab = true, ceiling_slab = true;
  // Walls and pillars stand from inside the floor slab to inside the ceiling slab.
  constexpr float wall_bottom() const { return -sink; }
  constexpr float wall_top() const { return ceiling + sink; }
};
// south_openings: in the wall along y = 0 (from, to along x).
void add_shell(TriangleMesh& mesh, const Shell& shell, const std::vector<Opening>& south_openings = {});

// `part` rotated by 180 degrees about the vertical line through `centre`, appended to `mesh`: a rotation
// keeps the triangles' winding, so normals stay outward.
void append_half_turn(TriangleMesh& mesh, const TriangleMesh& part, const Eigen::Vector2f& centre);

// Places furniture in one room: items against the walls, larger pieces in the middle, a clear zone in
// front of every door so the robot can get in.
class Furnisher {
 public:
  Furnisher(TriangleMesh& mesh, Rect interior, float floor, Rng rng)
      : mesh_(mesh), interior_(interior), floor_(floor), rng_(rng) {}

  void keep_clear(const Rect& r) { keep_out_.push_back(r); }

  // Free-standing pieces (fixed by the plan) first: wall items then keep a robot-sized aisle to them.
  void place_centre(const Rect& r, float height, bool legs);

  // Walks along each wall, placing pieces of the given kinds with random gaps.
  void line_walls(const std::vector<int>& kinds);

  static constexpr int kDesk = 0, kTallCabinet = 1, kSideboard = 2, kShelf = 3, kCounter = 4, kWhiteboard = 5;

 private:
  struct Piece {
    float width, depth, height, bottom;
    bool legs;
  };

  Piece piece(int kind);
  // side 0: south wall, 1: north, 2: west, 3: east; `at` runs along the wall.
  Rect footprint(int side, float at, float width, float depth) const;
  // Overlaps a clear zone, or comes within 5 cm of another piece.
  bool blocked(const Rect& r) const;
  bool near_centre(const Rect& r) const;
  // A table top on four legs: the LiDAR sees under it, the robot cannot drive there.
  void table(const Rect& r, float height);

  TriangleMesh& mesh_;
  Rect interior_;
  float floor_;
  Rng rng_;
  std::vector<Rect> keep_out_;
  std::vector<Rect> placed_;
  std::vector<Rect> centre_;
};

}  // namespace tsdf_mcl::sim
