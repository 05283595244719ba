#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "cli_test_support.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/render/image.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/render/map_view.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"

using Eigen::Vector3f;
using tsdf_mcl::test::TempDir;

using tsdf_mcl::test::CliResult;
using tsdf_mcl::test::expect_one_line_error;
using tsdf_mcl::test::run_cli;

namespace {

// A 4 x 3 m room: floor at z = 0, solid around it up to 1 m.
tsdf_mcl::TsdfMap small_room() {
  tsdf_mcl::TsdfMap map =
      tsdf_mcl::TsdfMap::covering(0.1f, 0.3f, Vector3f(-0.5f, -0.5f, -0.3f), Vector3f(4.5f, 3.5f, 1.2f));
  const Eigen::Vector3i lo = map.min_block() * tsdf_mcl::TsdfMap::kBlockSize;
  const Eigen::Vector3i hi = (map.min_block() + map.dims_blocks()) * tsdf_mcl::TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z) {
    for (int y = lo.y(); y < hi.y(); ++y) {
      for (int x = lo.x(); x < hi.x(); ++x) {
        const Vector3f p = map.center_of({x, y, z});
        const float inside_room = std::min({p.x(), 4.0f - p.x(), p.y(), 3.0f - p.y()});
        map.set_distance({x, y, z}, std::min(p.z(), std::max(-inside_room, p.z() - 1.0f)));
      }
    }
  }
  return map;
}

// Map, a ground-truth dataset, an estimate and two snapshots in dir.
void write_inputs(const TempDir& dir) {
  tsdf_mcl::save_map(small_room(), dir / "room.tsdf");
  std::vector<tsdf_mcl::StampedPose> estimate;
  {
    tsdf_mcl::DatasetWriter writer(dir / "data");
    tsdf_mcl::PointCloud scan;
    scan.points = {Vector3f(1.0f, 0.0f, 0.0f)};
    for (int i = 0; i < 10; ++i) {
      const tsdf_mcl::Pose pose = tsdf_mcl::pose_from_xyz_rpy(0.5 + 0.3 * i, 1.5, 0.5, 0, 0, 0.1 * i);
      writer.add(100.0 + i, scan, pose, std::nullopt);
      tsdf_mcl::Pose off = pose;
      off.translation().y() += 0.1;
      estimate.push_back({100.0 + i, off});
    }
    writer.close();
  }
  std::filesystem::create_directories(dir / "run");
  tsdf_mcl::write_tum(dir / "run/trajectory.tum", estimate);
  tsdf_mcl::ParticleSnapshot start, end;
  for (int i = 0; i < 200; ++i) {
    start.particles.push_back(
        {Vector3f(0.2f + 0.018f * i, 0.3f + 0.012f * i, 0.5f), Eigen::Quaternionf::Identity(), 1.0f});
    end.particles.push_back({Vector3f(3.2f, 1.6f, 0.5f), Eigen::Quaternionf::Identity(), 1.0f + static_cast<float>(i)});
  }
  // The filter's hypotheses travel with the particles (localize writes them): one holding the whole belief, and
  // one below the 1 % a picture marks.
  end.hypotheses.push_back({Vector3f(3.2f, 1.6f, 0.5f), Eigen::Quaternionf::Identity(), 0.995f});
  end.hypotheses.push_back({Vector3f(1.0f, 1.0f, 0.5f), Eigen::Quaternionf::Identity(), 0.005f});
  tsdf_mcl::write_particle_snapshot(dir / "start.part", start);
  tsdf_mcl::write_particle_snapshot(dir / "end.part", end);
}

}  // namespace

TEST(RenderCli, GoodRunWritesAPngOfTheExpectedSize) {
  TempDir dir;
  write_inputs(dir);
  const std::string d = "'" + dir.path().string() + "'";
  const CliResult r =
      run_cli(dir, "render --map " + d + "/room.tsdf --ground_truth " + d + "/data --estimate " + d +
                       "/run/trajectory.tum --particles " + d + "/start.part," + d +
                       "/end.part --captions 'start,end' --pixel 0.02 --title 'small room' -o " + d + "/out.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("out.png"), std::string::npos) << r.out;
  const tsdf_mcl::Image image = tsdf_mcl::load_png(dir / "out.png");

  // The library, given the same inputs, lays out the same figure.
  const tsdf_mcl::MapRaster raster(tsdf_mcl::load_map(dir / "room.tsdf"), {});
  std::vector<tsdf_mcl::TrajectoryOverlay> trajectories(2);
  trajectories[0].poses = tsdf_mcl::Dataset::open(dir / "data").poses();
  trajectories[0].label = "ground truth";
  for (const auto& s : tsdf_mcl::read_tum(dir / "run/trajectory.tum")) trajectories[1].poses.push_back(s.pose);
  trajectories[1].label = "run (final error 0.10 m, 0.0 deg)";
  std::vector<tsdf_mcl::MapPanel> panels(2);
  panels[0].particles = tsdf_mcl::read_particle_snapshot(dir / "start.part");
  panels[0].caption = "start  -  200 particles";
  panels[1].particles = tsdf_mcl::read_particle_snapshot(dir / "end.part");
  panels[1].caption = "end  -  200 particles";
  // The command marks the hypotheses each snapshot carries: "start" none, "end" one of its two (the other holds
  // less than 1 %).
  panels[0].markers = tsdf_mcl::hypothesis_markers(panels[0].particles);
  panels[1].markers = tsdf_mcl::hypothesis_markers(panels[1].particles);
  EXPECT_TRUE(panels[0].markers.empty());
  ASSERT_EQ(panels[1].markers.size(), 1u);
  EXPECT_LT((panels[1].markers[0].pose.translation() - Eigen::Vector3d(3.2, 1.6, 0.5)).norm(), 1e-5);
  EXPECT_EQ(panels[1].markers[0].annotation, "100 %");  // 99.5 % as printed
  tsdf_mcl::MapViewOptions options;
  options.metres_per_pixel = 0.02;
  options.title = "small room";
  const tsdf_mcl::MapFigure expected = tsdf_mcl::render_map_view(raster, trajectories, panels, options);
  EXPECT_EQ(image.width(), expected.image.width());
  EXPECT_EQ(image.height(), expected.image.height());
  // Two panels of (4 m + 2 x 0.5 m padding + the map's outer voxel) / 2 cm side by side.
  EXPECT_GT(image.width(), 2 * 250);
  EXPECT_GT(image.height(), 200);
}

TEST(RenderCli, SliceAndDefaultsWork) {
  TempDir dir;
  write_inputs(dir);
  const std::string d = "'" + dir.path().string() + "'";
  CliResult r = run_cli(dir, "render --map " + d + "/room.tsdf --slice 0.5 -o " + d + "/slice.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "render --map " + d + "/room.tsdf --z_min 0.2 --z_max 0.9 --particles " + d +
                       "/end.part --headings --panel_size 300 --output " + d + "/proj.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const tsdf_mcl::Image image = tsdf_mcl::load_png(dir / "proj.png");
  EXPECT_GE(image.width(), 300);
  r = run_cli(dir, "render --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--particles"), std::string::npos);
}

TEST(RenderCli, DrawsOnAMachineWithoutFonts) {
  // Fontconfig finds no font at all: Cairo's built-in font stands in, and the picture is the same size.
  TempDir dir;
  write_inputs(dir);
  tsdf_mcl::test::write_bytes(dir / "fonts.conf", "<?xml version=\"1.0\"?>\n<fontconfig><cachedir>" +
                                                      (dir / "cache").string() + "</cachedir></fontconfig>\n");
  const std::string d = "'" + dir.path().string() + "'";
  const std::string args = "render --map " + d + "/room.tsdf --ground_truth " + d + "/data --title 'no fonts' -o " + d;
  const CliResult with_fonts = run_cli(dir, args + "/fonts.png");
  ASSERT_EQ(with_fonts.exit_code, 0) << with_fonts.err;
  const char* before = std::getenv("FONTCONFIG_FILE");
  const std::string saved = before ? before : "";
  ::setenv("FONTCONFIG_FILE", (dir / "fonts.conf").c_str(), 1);  // for the program started next only
  const CliResult without = run_cli(dir, args + "/no_fonts.png");
  if (before)
    ::setenv("FONTCONFIG_FILE", saved.c_str(), 1);
  else
    ::unsetenv("FONTCONFIG_FILE");
  ASSERT_EQ(without.exit_code, 0) << without.err;
  const tsdf_mcl::Image a = tsdf_mcl::load_png(dir / "fonts.png"), b = tsdf_mcl::load_png(dir / "no_fonts.png");
  EXPECT_EQ(a.height(), b.height());
  EXPECT_NE(a.pixels(), b.pixels());  // in another font
}

TEST(RenderCli, BadInputExitsNonZeroWithOneLine) {
  TempDir dir;
  write_inputs(dir);
  const std::string d = "'" + dir.path().string() + "'";
  const std::string map = " --map " + d + "/room.tsdf";
  const std::string out = " -o " + d + "/x.png";
  expect_one_line_error(dir, "render" + map, "missing -o");
  expect_one_line_error(dir, "render" + out, "missing required option --map");
  expect_one_line_error(dir, "render --map " + d + "/none.tsdf" + out, "does not exist");
  tsdf_mcl::test::write_bytes(dir / "junk.tsdf", "this is not a map");
  expect_one_line_error(dir, "render --map " + d + "/junk.tsdf" + out, "not a tsdf-mcl map");
  expect_one_line_error(dir, "render" + map + " --pixel abc" + out, "--pixel expects a number");
  expect_one_line_error(dir, "render" + map + " --pixel -1" + out, "--pixel must be a positive");
  expect_one_line_error(dir, "render" + map + " --z_min 2 --z_max 1" + out, "z-range is empty");
  expect_one_line_error(dir, "render" + map + " --z_min 20" + out, "holds no voxel");
  expect_one_line_error(dir, "render" + map + " --slice 0.5 --z_min 0" + out, "excludes --z_min");
  expect_one_line_error(dir, "render" + map + " --slice 40" + out, "outside the map");
  expect_one_line_error(dir, "render" + map + " -o " + d + "/no/such/dir/x.png", "does not exist");
  expect_one_line_error(dir, "render" + map + " -o " + d + "/x.jpg", "must be a .png file");
  expect_one_line_error(dir, "render" + map + " --colour red" + out, "unknown option --colour");
  expect_one_line_error(dir, "render" + map + " extra" + out, "options only");
  expect_one_line_error(dir, "render" + map + " --particles " + d + "/none.part" + out, "does not exist");
  tsdf_mcl::test::write_bytes(dir / "bad.part", "TSDFPART\x01");
  expect_one_line_error(dir, "render" + map + " --particles " + d + "/bad.part" + out, "truncated");
  expect_one_line_error(dir, "render" + map + " --particles " + d + "/start.part --captions a,b" + out,
                        "2 captions for 1 particle snapshots");
  expect_one_line_error(dir, "render" + map + " --captions a" + out, "--captions needs --particles");
  expect_one_line_error(dir, "render" + map + " --estimate " + d + "/none.tum" + out, "none.tum");
  tsdf_mcl::test::write_bytes(dir / "empty.tum", "");
  expect_one_line_error(dir, "render" + map + " --estimate " + d + "/empty.tum" + out, "holds no poses");
  expect_one_line_error(dir, "render" + map + " --ground_truth " + d + "/nowhere" + out, "not a directory");
  expect_one_line_error(dir, "render" + map + " --pixel 0.00001" + out, "choose a larger pixel size");
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}
