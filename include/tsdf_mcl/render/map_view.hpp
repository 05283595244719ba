#pragma once
// Top-down pictures of a TSDF map, readable like a floor plan, with particles, trajectories and poses drawn over
// it. Two steps, so that many pictures of one map (panels, frames of a run) rasterize the map only once:
//
//   MapRaster raster(map, {});                        // the map, column by column (the costly part)
//   MapFigure figure = render_map_view(raster, {{"ground truth", gt_poses, colors::kBlack}},
//                                      {{"(a) start", start_particles}, {"(b) converged", end_particles}}, {});
//   save_png(figure.image, "run.png");
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/render/image.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

struct MapRasterOptions {
  // Projection: only surfaces whose voxel centres lie in [z_min, z_max] count (default: the whole map). Narrow it to
  // leave out e.g. the ceiling or low clutter.
  std::optional<float> z_min;
  std::optional<float> z_max;
  // A horizontal slice through the voxels nearest this height instead of a projection.
  std::optional<float> slice_z;
};

// The map seen from above, one cell per voxel column (x, y) of the map's block box.
//
// Projection: a column is an obstacle where it holds surface voxels (|d| < one voxel) whose surface faces sideways
// (walls, furniture, poles, steps) over at least two voxels of height; floors, ramps and ceilings face up or down
// and do not count, so the default z-range already gives a floor plan. The obstacle's value is the height of its
// highest such voxel. Columns with any other known voxel in the z-range are free, the rest unknown.
// Slice: each column's voxel at the slice height: unknown, free (d >= one voxel), surface or inside (d <= -one
// voxel); the value is the signed distance.
class MapRaster {
 public:
  enum class Cell : std::uint8_t { kUnknown, kFree, kObstacle, kSurface, kInside };

  // Throws Error for an empty map, a z-range that is empty or outside the map, or a slice outside the map.
  MapRaster(const TsdfMap& map, const MapRasterOptions& options);

  bool is_slice() const { return slice_; }
  float voxel_size() const { return voxel_size_; }
  float truncation() const { return truncation_; }
  // Heights covered: the z-range of a projection, the slice voxel's centre twice for a slice.
  float z_min() const { return z_min_; }
  float z_max() const { return z_max_; }
  // Lowest and highest obstacle height found (projection; the z-range if there is no obstacle).
  float obstacle_min() const { return obstacle_min_; }
  float obstacle_max() const { return obstacle_max_; }

  // Column (i, j) is the voxel column centred at (first_column + (i, j)) * voxel_size.
  const Eigen::Vector2i& first_column() const { return first_column_; }
  int columns_x() const { return nx_; }
  int columns_y() const { return ny_; }
  Cell cell(int i, int j) const { return cells_[index(i, j)]; }
  float value(int i, int j) const { return values_[index(i, j)]; }
  // The column containing a world point; nullopt outside the map.
  std::optional<Eigen::Vector2i> column_at(const Eigen::Vector2d& world) const;
  Eigen::Vector2d column_center(int i, int j) const;
  // World bounds of the columns that are not unknown; nullopt if there are none.
  std::optional<Eigen::AlignedBox2d> known_bounds() const;

  // The colour a view paints a column in: unknown grey, free white, obstacles by height (reversed viridis over
  // obstacle_min..obstacle_max: the tallest darkest), slices by signed distance.
  Rgb color(int i, int j) const;

 private:
  std::size_t index(int i, int j) const { return static_cast<std::size_t>(j) * nx_ + i; }
  // The constructor's stages. The voxel rows (z index) the raster covers, a slice's one or the z-range's, with
  // slice_ set; errors name the map's z `range`.
  std::pair<int, int> voxel_z_range(const TsdfMap& map, const MapRasterOptions& options, const std::string& range);
  // Every block of those rows into the columns: a slice's distances, or free columns and, per column, the
  // near-vertical surface voxels (counted in obstacle_voxels, the highest one's z kept as the value).
  void rasterize(const TsdfMap& map, int k_lo, int k_hi, std::vector<std::uint8_t>& obstacle_voxels);
  void fill_free_block(int cx, int cy);  // a block known free: its unknown columns become free
  // One block with voxels (`block`: its index from the map's min_block), rows lz_lo..lz_hi of it.
  void rasterize_block(const TsdfMap& map, std::uint32_t entry, const Eigen::Vector3i& block, int lz_lo, int lz_hi,
                       std::vector<std::uint8_t>& obstacle_voxels);
  // Columns with enough near-vertical surface become obstacles; the obstacle height range for the colours.
  void classify_obstacles(const std::vector<std::uint8_t>& obstacle_voxels);

  bool slice_ = false;
  float voxel_size_ = 0.0f;
  float truncation_ = 0.0f;
  float z_min_ = 0.0f, z_max_ = 0.0f;
  float obstacle_min_ = 0.0f, obstacle_max_ = 0.0f;
  Eigen::Vector2i first_column_ = Eigen::Vector2i::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<Cell> cells_;
  std::vector<float> values_;
};

// A trajectory drawn in every panel: a line through the positions (broken where consecutive poses jump, as a
// global localization's early estimates do), a ring at the start and an arrow along the heading at the end.
struct TrajectoryOverlay {
  std::string label{};  // legend text
  std::vector<Pose> poses{};
  Rgb color = colors::kBlack;
  float width = 2.0f;  // pixels
  float alpha = 1.0f;  // a wide translucent line under the others suits a ground truth: deviations show beside it
  bool dashed = false;
};

// A single pose drawn as a large arrow (e.g. the current estimate, or one hypothesis of a multimodal belief).
struct PoseMarker {
  Pose pose = Pose::Identity();
  Rgb color = rgb_hex(0xd62728);
  std::string label{};       // legend text; empty = not listed
  std::string annotation{};  // written beside the arrow (e.g. "55 %"); empty = none
};

// The belief's hypotheses (modes) as the filter found them (the snapshot's, best first): up to four holding at
// least 1 % of the weight, each an arrow at its mean pose with its share written beside it ("two rooms, 55 % /
// 45 %"). A snapshot without hypotheses (format version 1) gets none.
std::vector<PoseMarker> hypothesis_markers(const ParticleSnapshot& snapshot);

// One panel: the map with the trajectories and its own particles and markers, captioned above.
struct MapPanel {
  std::string caption{};
  ParticleSnapshot particles{};
  std::vector<PoseMarker> markers{};
};

struct MapViewOptions {
  double metres_per_pixel = 0.0;  // 0: the larger side of a panel gets about panel_pixels pixels
  int panel_pixels = 1000;
  std::string title;
  double padding = 0.5;  // metres shown around the known map and the overlays
  // Particles are coloured by weight (log scale over three decades) unless their weights are all equal (as after
  // resampling); then they all get particle_color.
  Rgb particle_color = rgb_hex(0xd62728);
  float particle_radius = 1.5f;    // pixels
  float particle_alpha = 0.6f;     // at most; lowered when the particles would cover most of a panel
  bool particle_headings = false;  // a short tick along each particle's heading
  float text_scale = 0.0f;         // see TextStyle::scale; 0 = from the panel size (1.5 .. 2.5)
};

// The rendered figure and, per panel, the transform from world coordinates to the figure's pixels.
struct MapFigure {
  Image image;
  std::vector<TopDownTransform> panels;
};

// No panels gives one panel without particles. Throws Error when there is nothing to show (no known column and no
// overlay) or the figure would exceed the image size limit.
MapFigure render_map_view(const MapRaster& raster, const std::vector<TrajectoryOverlay>& trajectories,
                          const std::vector<MapPanel>& panels, const MapViewOptions& options);

}  // namespace tsdf_mcl
