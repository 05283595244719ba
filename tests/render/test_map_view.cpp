#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/map_view.hpp"

using Eigen::Vector2d;
using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::Error;
using tsdf_mcl::MapRaster;
using tsdf_mcl::Rgb;
using tsdf_mcl::TsdfMap;
namespace colors = tsdf_mcl::colors;

namespace {

constexpr float kVoxel = 0.05f;
constexpr float kWallX = 1.0f;
constexpr float kWallTop = 1.2f;

// A floor at z = 0 (solid below), a 5 cm thick wall centred on x = 1 from the floor to z = 1.2 along the whole map,
// free space elsewhere; everything beyond y = 1.5 is unobserved.
TsdfMap room_map() {
  TsdfMap map = TsdfMap::covering(kVoxel, 0.15f, Vector3f(-1.0f, -1.0f, -0.4f), Vector3f(3.0f, 2.0f, 1.6f));
  const Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z) {
    for (int y = lo.y(); y < hi.y(); ++y) {
      for (int x = lo.x(); x < hi.x(); ++x) {
        const Vector3f p = map.center_of({x, y, z});
        if (p.y() > 1.5f) continue;
        const float floor = p.z();
        const float wall = std::max({kWallX - 0.025f - p.x(), p.x() - kWallX - 0.025f, p.z() - kWallTop});
        map.set_distance({x, y, z}, std::min(floor, wall));
      }
    }
  }
  return map;
}

const TsdfMap& shared_room() {
  static const TsdfMap map = room_map();
  return map;
}

MapRaster::Cell cell_at(const MapRaster& raster, const Vector2d& world) {
  const auto c = raster.column_at(world);
  EXPECT_TRUE(c.has_value()) << world.transpose();
  return c ? raster.cell(c->x(), c->y()) : MapRaster::Cell::kUnknown;
}

Rgb color_at(const MapRaster& raster, const Vector2d& world) {
  const auto c = raster.column_at(world);
  return raster.color(c->x(), c->y());
}

Rgb pixel_at(const tsdf_mcl::MapFigure& figure, std::size_t panel, const Vector2d& world) {
  const Eigen::Vector2f p = figure.panels.at(panel).to_pixel(world);
  return figure.image.at(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())));
}

// Many panels form a grid close to a screen's shape (issue 17: a strip of five was unreadable at screen width):
// five panels of a square room are three columns of two rows, each caption above its own panel.
TEST(RenderMapView, ManyPanelsFormAGrid) {
  const MapRaster raster(shared_room(), {});
  std::vector<tsdf_mcl::MapPanel> panels(5);
  for (std::size_t k = 0; k < panels.size(); ++k) panels[k].caption = "(" + std::to_string(k) + ")";
  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = kVoxel;
  const auto figure = tsdf_mcl::render_map_view(raster, {}, panels, options);
  ASSERT_EQ(figure.panels.size(), 5u);
  EXPECT_EQ(figure.panels[3].area().x(), figure.panels[0].area().x());  // the second row starts under the first
  EXPECT_GT(figure.panels[3].area().y(), figure.panels[0].area().w());
  EXPECT_GT(figure.panels[2].area().x(), figure.panels[1].area().z());
  EXPECT_EQ(figure.panels[2].area().y(), figure.panels[0].area().y());
  EXPECT_LT(figure.image.width(), 2 * figure.image.height());
}

}  // namespace

TEST(RenderMapView, WallsAreObstaclesFloorsAreFree) {
  const MapRaster raster(shared_room(), {});
  EXPECT_FALSE(raster.is_slice());
  for (double y : {-0.8, 0.0, 1.4}) {
    EXPECT_EQ(cell_at(raster, {kWallX, y}), MapRaster::Cell::kObstacle) << y;
    EXPECT_EQ(cell_at(raster, {0.0, y}), MapRaster::Cell::kFree) << y;  // the floor faces up: not an obstacle
    EXPECT_EQ(cell_at(raster, {2.0, y}), MapRaster::Cell::kFree) << y;
  }
  EXPECT_EQ(cell_at(raster, {0.0, 1.8}), MapRaster::Cell::kUnknown);
  const auto wall = raster.column_at({kWallX, 0.0});
  EXPECT_NEAR(raster.value(wall->x(), wall->y()), kWallTop, 0.051);
  EXPECT_NEAR(raster.obstacle_max(), kWallTop, 0.051);
  EXPECT_EQ(color_at(raster, {0.0, 0.0}), colors::kWhite);
  EXPECT_NE(color_at(raster, {kWallX, 0.0}), colors::kWhite);
  EXPECT_NE(color_at(raster, {0.0, 1.8}), colors::kWhite);
  EXPECT_NE(color_at(raster, {0.0, 1.8}), color_at(raster, {kWallX, 0.0}));

  const auto known = raster.known_bounds();
  ASSERT_TRUE(known.has_value());
  EXPECT_NEAR(known->max().y(), 1.525, 1e-4);  // the last observed column row is centred at 1.5
  EXPECT_LT(known->min().x(), -0.99);
}

TEST(RenderMapView, WallShowsInTheRightPixelColumn) {
  const MapRaster raster(shared_room(), {});
  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = kVoxel;
  const tsdf_mcl::MapFigure figure = tsdf_mcl::render_map_view(raster, {}, {}, options);
  ASSERT_EQ(figure.panels.size(), 1u);
  // A pixel straddles two columns; it shows one of the wall's.
  auto wall_color = [&](Rgb c) {
    for (const float x : {kWallX - kVoxel, kWallX, kWallX + kVoxel}) {
      if (c == color_at(raster, {x, 0.0}) && cell_at(raster, {x, 0.0}) == MapRaster::Cell::kObstacle) return true;
    }
    return false;
  };
  EXPECT_TRUE(wall_color(pixel_at(figure, 0, {kWallX, 0.0})));
  EXPECT_TRUE(wall_color(pixel_at(figure, 0, {kWallX, -0.5})));
  EXPECT_EQ(pixel_at(figure, 0, {0.0, 0.0}), colors::kWhite);
  EXPECT_EQ(pixel_at(figure, 0, {2.0, 0.5}), colors::kWhite);
  EXPECT_EQ(pixel_at(figure, 0, {0.0, 1.8}), color_at(raster, {0.0, 1.8}));

  // Along one row of pixels (right of the scale bar), obstacle colours occur only at the wall.
  const Eigen::Vector4i area = figure.panels[0].area();
  const int row = static_cast<int>(figure.panels[0].to_pixel({0.0, 0.25}).y());
  int wall_pixels = 0;
  for (int x = static_cast<int>(figure.panels[0].to_pixel({0.0, 0.0}).x()); x < area.z(); ++x) {
    const Rgb c = figure.image.at(x, row);
    if (c == colors::kWhite || c == color_at(raster, {0.0, 1.8})) continue;
    const double world_x = figure.panels[0].to_world({static_cast<float>(x) + 0.5f, static_cast<float>(row)}).x();
    EXPECT_NEAR(world_x, kWallX, 0.11) << x;
    ++wall_pixels;
  }
  EXPECT_GE(wall_pixels, 3);
  EXPECT_LE(wall_pixels, 5);
}

TEST(RenderMapView, ThinWallsSurviveCoarsePixels) {
  const MapRaster raster(shared_room(), {});
  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = 0.2;  // four voxels per pixel
  const tsdf_mcl::MapFigure figure = tsdf_mcl::render_map_view(raster, {}, {}, options);
  const Rgb c = pixel_at(figure, 0, {kWallX, 0.0});
  EXPECT_NE(c, colors::kWhite);
  EXPECT_NE(c, color_at(raster, {0.0, 1.8}));
  EXPECT_EQ(pixel_at(figure, 0, {0.2, 0.0}), colors::kWhite);
}

TEST(RenderMapView, ZRangeLeavesOutWhatIsOutsideIt) {
  tsdf_mcl::MapRasterOptions options;
  options.z_min = 1.3f;
  const MapRaster above(shared_room(), options);
  EXPECT_EQ(cell_at(above, {kWallX, 0.0}), MapRaster::Cell::kFree);
  EXPECT_NEAR(above.z_min(), 1.3f, 1e-4);
  options.z_min = 0.5f;
  options.z_max = 0.8f;
  const MapRaster band(shared_room(), options);
  const auto wall = band.column_at({kWallX, 0.0});
  EXPECT_EQ(band.cell(wall->x(), wall->y()), MapRaster::Cell::kObstacle);
  EXPECT_NEAR(band.value(wall->x(), wall->y()), 0.8, 1e-4);
}

TEST(RenderMapView, SliceShowsSignedDistance) {
  tsdf_mcl::MapRasterOptions options;
  options.slice_z = 0.6f;
  const MapRaster slice(shared_room(), options);
  EXPECT_TRUE(slice.is_slice());
  EXPECT_NEAR(slice.z_min(), 0.6f, 1e-5);
  EXPECT_EQ(cell_at(slice, {kWallX, 0.0}), MapRaster::Cell::kSurface);
  EXPECT_EQ(cell_at(slice, {0.0, 0.0}), MapRaster::Cell::kFree);
  EXPECT_EQ(cell_at(slice, {0.0, 1.8}), MapRaster::Cell::kUnknown);
  EXPECT_EQ(color_at(slice, {0.0, 0.0}), colors::kWhite);  // beyond the truncation band
  const Rgb near_wall = color_at(slice, {0.9, 0.0});       // 7.5 cm in front of the wall: tinted
  EXPECT_NE(near_wall, colors::kWhite);
  EXPECT_NE(near_wall, color_at(slice, {kWallX, 0.0}));
  const auto c = slice.column_at({0.9, 0.0});
  EXPECT_NEAR(slice.value(c->x(), c->y()), 0.075, 0.01);
  EXPECT_NO_THROW(tsdf_mcl::render_map_view(slice, {}, {}, {}));
}

TEST(RenderMapView, FreeBlocksAreFreeColumns) {
  TsdfMap map = TsdfMap::covering(0.1f, 0.3f, Vector3f(0.0f, 0.0f, 0.0f), Vector3f(3.0f, 3.0f, 1.0f));
  map.mark_block_free({0, 0, 0});
  const MapRaster raster(map, {});
  EXPECT_EQ(cell_at(raster, {0.3, 0.3}), MapRaster::Cell::kFree);
  EXPECT_EQ(cell_at(raster, {2.5, 2.5}), MapRaster::Cell::kUnknown);
  tsdf_mcl::MapRasterOptions slice_options;
  slice_options.slice_z = 0.2f;
  EXPECT_EQ(cell_at(MapRaster(map, slice_options), {0.3, 0.3}), MapRaster::Cell::kFree);
}

TEST(RenderMapView, BadOptionsThrow) {
  EXPECT_THROW(MapRaster(TsdfMap(), {}), Error);
  tsdf_mcl::MapRasterOptions options;
  options.z_min = 1.0f;
  options.z_max = 0.5f;
  EXPECT_THROW(MapRaster(shared_room(), options), Error);
  options.z_min = 10.0f;
  options.z_max = 12.0f;
  EXPECT_THROW(MapRaster(shared_room(), options), Error);
  options = {};
  options.slice_z = 50.0f;
  EXPECT_THROW(MapRaster(shared_room(), options), Error);
  options.slice_z = 0.5f;
  options.z_min = 0.0f;
  EXPECT_THROW(MapRaster(shared_room(), options), Error);

  // Nothing known and nothing to overlay: no picture to make.
  const TsdfMap empty = TsdfMap::covering(0.1f, 0.3f, Vector3f::Zero(), Vector3f::Ones());
  const MapRaster blank(empty, {});
  EXPECT_FALSE(blank.known_bounds().has_value());
  EXPECT_THROW(tsdf_mcl::render_map_view(blank, {}, {}, {}), Error);
  tsdf_mcl::MapViewOptions huge;
  huge.metres_per_pixel = 1e-5;
  EXPECT_THROW(tsdf_mcl::render_map_view(MapRaster(shared_room(), {}), {}, {}, huge), Error);
}

TEST(RenderMapView, OverlaysLandWhereTheyBelong) {
  const MapRaster raster(shared_room(), {});
  const Rgb path_color{0, 0, 230}, particle_color{230, 0, 0}, marker_color{0, 160, 0};

  tsdf_mcl::TrajectoryOverlay path;
  path.label = "estimate";
  path.color = path_color;
  path.width = 3.0f;
  for (int i = 0; i <= 20; ++i) path.poses.push_back(tsdf_mcl::pose_from_xyz_rpy(-0.5 + 0.05 * i, -0.5, 0.0, 0, 0, 0));

  tsdf_mcl::MapPanel empty_panel{"(a) start", {}, {}};
  tsdf_mcl::MapPanel particle_panel{"(b) particles", {}, {}};
  particle_panel.particles.particles.push_back({Vector3f(0.0f, 0.5f, 0.0f), Eigen::Quaternionf::Identity(), 1.0f});
  particle_panel.markers.push_back({tsdf_mcl::pose_from_xyz_rpy(2.0, -0.5, 0.0, 0, 0, 1.0), marker_color, "estimate"});

  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = kVoxel;
  options.particle_color = particle_color;
  options.particle_alpha = 1.0f;
  options.particle_radius = 3.0f;
  options.title = "overlays";
  const auto figure = tsdf_mcl::render_map_view(raster, {path}, {empty_panel, particle_panel}, options);
  ASSERT_EQ(figure.panels.size(), 2u);
  EXPECT_EQ(figure.panels[0].width(), figure.panels[1].width());
  EXPECT_GT(figure.panels[1].area().x(), figure.panels[0].area().z());  // side by side

  for (std::size_t k = 0; k < 2; ++k) EXPECT_EQ(pixel_at(figure, k, {0.0, -0.5}), path_color);
  EXPECT_EQ(pixel_at(figure, 1, {0.0, 0.5}), particle_color);
  EXPECT_EQ(pixel_at(figure, 0, {0.0, 0.5}), colors::kWhite);  // the particle belongs to panel (b) only
  EXPECT_EQ(pixel_at(figure, 1, {2.0, -0.5}), marker_color);
  EXPECT_EQ(pixel_at(figure, 0, {2.0, -0.5}), colors::kWhite);

  // The view grows to show overlays outside the known map.
  tsdf_mcl::TrajectoryOverlay far;
  far.poses = {tsdf_mcl::pose_from_xyz_rpy(6.0, 4.0, 0.0, 0, 0, 0)};
  const auto grown = tsdf_mcl::render_map_view(raster, {far}, {}, options);
  const Eigen::Vector2f p = grown.panels[0].to_pixel({6.0, 4.0});
  const Eigen::Vector4i area = grown.panels[0].area();
  EXPECT_TRUE(p.x() > area.x() && p.x() < area.z() && p.y() > area.y() && p.y() < area.w());
}

TEST(RenderMapView, WeightedParticlesGetAColourScale) {
  const MapRaster raster(shared_room(), {});
  tsdf_mcl::MapPanel panel;
  panel.particles.particles = {{Vector3f(0.0f, 0.0f, 0.0f), Eigen::Quaternionf::Identity(), 0.999f},
                               {Vector3f(2.0f, 0.0f, 0.0f), Eigen::Quaternionf::Identity(), 0.001f}};
  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = kVoxel;
  options.particle_alpha = 1.0f;
  options.particle_radius = 3.0f;
  options.particle_headings = true;
  const auto figure = tsdf_mcl::render_map_view(raster, {}, {panel}, options);
  const Rgb heavy = pixel_at(figure, 0, {0.0, 0.0}), light = pixel_at(figure, 0, {2.0, 0.0});
  EXPECT_EQ(heavy, options.particle_color);
  EXPECT_NE(light, colors::kWhite);
  EXPECT_NE(light, heavy);
  EXPECT_GT(light.g, heavy.g);  // paler
}
