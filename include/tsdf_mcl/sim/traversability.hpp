#pragma once
// Where a ground robot can drive in a mesh: a 2D grid over the mesh's footprint holding, per cell, the floor
// height and whether the robot's centre may be there.
//
// Floor of a cell: the lowest near-horizontal surface under its centre with room for the robot above it
// (found by casting a ray down through every surface). Lowest, not largest: in a closed building the roof
// is a bigger flat region than any floor. A cell is blocked when geometry reaches into the band between a
// step and the robot's height above its floor, or when a neighbour's floor is missing or a step too far
// away (a cliff). The robot's centre keeps its radius from blocked cells. Of the connected regions that
// leaves, the traversable floor is the one with the most enclosed floor (where horizontal rays hit the mesh
// in nearly every direction), the largest among equals: indoors wins over the open ground around a
// building standing on a ground plane. In the open air (streets between buildings) the largest region wins.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "tsdf_mcl/io/mesh.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

class TraversabilityGrid {
 public:
  // Floors below min_floor_z are ignored (geometry under an added ground plane). open_air: the largest region is
  // the traversable floor, with no test of enclosure. Throws Error when the mesh leaves no traversable region.
  TraversabilityGrid(const RayCaster& scene, const TriangleMesh& mesh, const RobotModel& robot, double cell = 0.1,
                     double min_floor_z = -std::numeric_limits<double>::infinity(), bool open_air = false);

  int width() const { return width_; }
  int height() const { return height_; }
  double cell() const { return cell_; }
  std::size_t size() const { return floor_.size(); }

  int index(int ix, int iy) const { return iy * width_ + ix; }
  int index_of(const Eigen::Vector2d& p) const;  // -1 outside the grid
  Eigen::Vector2i coords(int index) const { return {index % width_, index / width_}; }
  Eigen::Vector2d center(int index) const;

  bool free(int index) const { return free_[static_cast<std::size_t>(index)] != 0; }  // in the traversable region
  float floor(int index) const { return floor_[static_cast<std::size_t>(index)]; }    // NaN: no floor
  bool passable(int index) const { return passable_[static_cast<std::size_t>(index)] != 0; }  // floor, no obstacle
  float clearance(int index) const { return clearance_[static_cast<std::size_t>(index)]; }    // m to a blocked cell
  float slope_deg(int index) const { return slope_deg_[static_cast<std::size_t>(index)]; }

  const std::vector<int>& free_cells() const { return free_cells_; }
  // Takes the cells whose centres lie in any of `areas` (x, y rectangles: min, max) out of the traversable
  // region: a mapping route that skips rooms (the map then leaves them unobserved but for what the sensor sees
  // through their doors). Throws Error when less than 1 m^2 stays.
  void exclude(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& areas);
  double free_area() const { return static_cast<double>(free_cells_.size()) * cell_ * cell_; }

 private:
  // The constructor's stages, in order.
  // Floors: every near-horizontal surface under a cell's centre with the robot's headroom above it.
  void find_floors(const RayCaster& scene, const RobotModel& robot, double min_floor_z);
  // Cells where a triangle reaches into the band between a step and the robot's height above the floor.
  std::vector<std::uint8_t> find_obstacles(const TriangleMesh& mesh, const RobotModel& robot) const;
  // passable_ = floor and no obstacle; returns the cells with a floor.
  std::size_t mark_passable(const std::vector<std::uint8_t>& obstacle);
  // No passable floor, or a cliff to a neighbour (missing floor or a step higher than max_step).
  std::vector<std::uint8_t> find_blocked(double max_step) const;
  // clearance_: distance to the nearest blocked cell.
  void compute_clearance(const std::vector<std::uint8_t>& blocked);
  // Where the robot fits: not blocked, at least `needed` from a blocked cell.
  bool candidate(const std::vector<std::uint8_t>& blocked, float needed, std::size_t i) const;
  // Every third candidate cell: whether horizontal rays hit the mesh in nearly every direction (indoors).
  std::vector<std::uint8_t> find_enclosed(const RayCaster& scene, const RobotModel& robot,
                                          const std::vector<std::uint8_t>& blocked, float needed) const;
  // free_ / free_cells_: the connected candidate region with the most enclosed cells (the larger among equals).
  void choose_free_region(const std::vector<std::uint8_t>& blocked, float needed,
                          const std::vector<std::uint8_t>& enclosed);

  double cell_;
  int width_ = 0;
  int height_ = 0;
  Eigen::Vector2d origin_;  // corner of cell (0, 0)
  std::vector<float> floor_;
  std::vector<float> slope_deg_;
  std::vector<std::uint8_t> passable_;
  std::vector<float> clearance_;
  std::vector<std::uint8_t> free_;
  std::vector<int> free_cells_;
};

}  // namespace tsdf_mcl::sim
