// tsdf-mcl render: a map seen from above with ground truth, estimated trajectories and particle snapshots, as PNG.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/image.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/render/map_view.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/eval/trajectory_metrics.hpp"

namespace tsdf_mcl::cli {
namespace fs = std::filesystem;
namespace {

std::vector<OptionSpec> render_options() {
  return {
      {"map", "MAP", "", "map file (.tsdf) to draw"},
      {"z_min", "M", "", "projection: lowest voxel height to include (m) [default: the map's bottom]"},
      {"z_max", "M", "", "projection: highest voxel height to include (m) [default: the map's top]"},
      {"slice", "Z", "", "draw the horizontal slice at height Z (m) instead of a projection"},
      {"ground_truth", "DIR", "", "dataset folder whose poses.txt is drawn as the ground truth trajectory"},
      {"estimate", "FILE[,FILE..]", "", "estimated trajectories (TUM: t x y z qx qy qz qw), comma-separated"},
      {"particles", "FILE[,FILE..]", "", "particle snapshots written by localize, comma-separated: one panel each"},
      {"captions", "TEXT[,TEXT..]", "", "one caption per particle snapshot [default: (a) FILE, (b) FILE, ...]"},
      {"headings", "", "", "draw each particle's heading as a short tick"},
      {"pixel", "M", "", "metres per pixel [default: fit --panel_size]"},
      {"panel_size", "PX", "0",
       "larger side of each panel in pixels when --pixel is not given; 0 = 1000 for one "
       "panel, 700 each for several"},
      {"title", "TEXT", "", "title above the picture"},
      {"output", "FILE.png", "", "image to write (same as -o FILE.png)"},
  };
}

// A trajectory's legend name: the file's stem, or its folder's name for localize's OUT/trajectory.tum.
std::string trajectory_name(const fs::path& file) {
  const std::string stem = file.stem().string();
  const std::string parent = file.parent_path().filename().string();
  if (stem == "trajectory" && !parent.empty() && parent != "." && parent != "..") return parent;
  return stem;
}

// Position and heading error of the estimate's last pose against the ground truth pose nearest in time, if one is
// within half a ground-truth period (the estimate's stamps are the dataset's scan times).
std::string final_error_note(const std::vector<StampedPose>& estimate, const Dataset& truth) {
  const auto& times = truth.times();
  if (estimate.empty() || times.size() < 2) return "";
  std::vector<double> periods;
  for (std::size_t i = 1; i < times.size(); ++i) periods.push_back(std::abs(times[i] - times[i - 1]));
  std::nth_element(periods.begin(), periods.begin() + static_cast<std::ptrdiff_t>(periods.size() / 2), periods.end());
  const double tolerance = 0.5 * periods[periods.size() / 2];
  const StampedPose& last = estimate.back();
  const std::optional<std::size_t> nearest = nearest_stamp(times, last.time, tolerance);
  if (!nearest) return "";
  const Pose& gt = truth.pose(*nearest);
  const double position = (last.pose.translation() - gt.translation()).norm();
  const double angle = rotation_angle_between(last.pose.linear(), gt.linear()) * 180.0 / EIGEN_PI;
  char note[96];
  std::snprintf(note, sizeof(note), " (final error %.2f m, %.1f deg)", position, angle);
  return note;
}

// What the options draw and where, checked before the (possibly large) map is loaded.
struct RenderSettings {
  fs::path output;
  MapRasterOptions raster;
  MapViewOptions view;
  std::vector<std::string> particle_files;
  std::vector<std::string> captions;
};

RenderSettings render_settings(const Options& o) {
  RenderSettings r;
  if (!o.has("output")) throw Error("missing -o OUT.png (the image to write)");
  r.output = o.text("output");
  std::string extension = r.output.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (extension != ".png") throw Error("the output must be a .png file, got " + r.output.string());
  check_output_file(r.output, "image");
  if (o.has("z_min")) r.raster.z_min = static_cast<float>(o.number("z_min"));
  if (o.has("z_max")) r.raster.z_max = static_cast<float>(o.number("z_max"));
  if (o.has("slice")) {
    if (o.has("z_min") || o.has("z_max")) throw Error("--slice draws one height; it excludes --z_min/--z_max");
    r.raster.slice_z = static_cast<float>(o.number("slice"));
  }
  if (o.has("pixel")) {
    r.view.metres_per_pixel = o.number("pixel");
    if (!(r.view.metres_per_pixel > 0.0)) throw Error("--pixel must be a positive number of metres");
  }
  if (o.has("particles")) r.particle_files = o.list("particles");
  if (o.has("captions")) {
    if (r.particle_files.empty()) throw Error("--captions needs --particles (one caption per snapshot)");
    r.captions = o.list("captions");
    if (r.captions.size() != r.particle_files.size()) {
      throw Error("" + std::to_string(r.captions.size()) + " captions for " + std::to_string(r.particle_files.size()) +
                  " particle snapshots");
    }
  }
  const std::size_t panel_size = o.count("panel_size");
  r.view.panel_pixels = panel_size != 0               ? static_cast<int>(std::min<std::size_t>(panel_size, 32768))
                        : r.particle_files.size() > 1 ? 700
                                                      : 1000;
  r.view.particle_headings = o.flag("headings");
  if (o.has("title")) r.view.title = o.text("title");
  return r;
}

// The ground truth (if given) under the estimates, each estimate in a colour of its own.
std::vector<TrajectoryOverlay> trajectory_overlays(const Options& o) {
  std::vector<TrajectoryOverlay> trajectories;
  std::optional<Dataset> truth;
  if (o.has("ground_truth")) {
    truth = Dataset::open(o.text("ground_truth"));
    if (!truth->has_poses()) throw Error("--ground_truth " + o.text("ground_truth") + " has no poses.txt");
    // Wide and translucent, under the estimates: where an estimate leaves the band, it is wrong there.
    trajectories.push_back({"ground truth", truth->poses(), colors::kBlack, 7.0f, 0.3f, false});
  }
  if (o.has("estimate")) {
    // Colours of the categorical palette without red (the particles') and grey (unobserved space).
    static constexpr std::size_t kEstimateColors[] = {0, 1, 4, 2, 6, 9, 5, 8};
    const std::vector<std::string> files = o.list("estimate");
    for (std::size_t i = 0; i < files.size(); ++i) {
      const std::vector<StampedPose> stamped = read_tum(files[i]);
      if (stamped.empty()) throw Error("estimate " + files[i] + " holds no poses");
      TrajectoryOverlay t;
      t.label = trajectory_name(files[i]) + (truth ? final_error_note(stamped, *truth) : "");
      t.color = palette_color(kEstimateColors[i % std::size(kEstimateColors)]);
      t.width = 2.0f;
      for (const auto& s : stamped) t.poses.push_back(s.pose);
      trajectories.push_back(std::move(t));
    }
  }
  return trajectories;
}

// A panel per particle snapshot, captioned by --captions or the file's name ((a), (b), ... when several).
std::vector<MapPanel> particle_panels(const std::vector<std::string>& particle_files,
                                      const std::vector<std::string>& captions) {
  std::vector<MapPanel> panels;
  for (std::size_t i = 0; i < particle_files.size(); ++i) {
    MapPanel panel;
    panel.particles = read_particle_snapshot(particle_files[i]);
    panel.caption = captions.empty() ? fs::path(particle_files[i]).stem().string() : captions[i];
    if (captions.empty() && particle_files.size() > 1) {
      panel.caption = "(" + std::string(1, static_cast<char>('a' + i % 26)) + ") " + panel.caption;
    }
    panel.caption += "  -  " + std::to_string(panel.particles.particles.size()) + " particles";
    panel.markers = hypothesis_markers(panel.particles);
    panels.push_back(std::move(panel));
  }
  return panels;
}

}  // namespace

int run_render(int argc, char** argv) {
  // "-o FILE" is the command-line contract's short form of --output.
  std::vector<std::string> args(argv, argv + argc);
  for (auto& a : args) {
    if (a == "-o") a = "--output";
  }
  std::vector<char*> arg_ptrs;
  for (auto& a : args) arg_ptrs.push_back(a.data());
  const Options o(
      "render",
      "tsdf-mcl render --map MAP [--z_min M --z_max M | --slice Z] [--ground_truth DIR]\n"
      "                       [--estimate FILE.tum,..] [--particles FILE,.. [--captions A,..]] [--pixel M]\n"
      "                       [--title TEXT] -o OUT.png\n"
      "Draws the map from above like a floor plan (obstacles coloured by height, free space white,\n"
      "unobserved space grey) with the trajectories and particles over it; several particle snapshots\n"
      "become panels in a grid.",
      render_options(), argc, arg_ptrs.data(), 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "options only, e.g. --map MAP -o OUT.png");

  // Option errors are reported before the (possibly large) map is loaded.
  const RenderSettings r = render_settings(o);
  const TsdfMap map = load_map(o.text("map"));
  const std::vector<TrajectoryOverlay> trajectories = trajectory_overlays(o);
  const std::vector<MapPanel> panels = particle_panels(r.particle_files, r.captions);

  const MapRaster raster(map, r.raster);
  const MapFigure figure = render_map_view(raster, trajectories, panels, r.view);
  save_png(figure.image, r.output);
  std::printf("wrote %s (%d x %d pixels, %.3f m per pixel)\n", r.output.string().c_str(), figure.image.width(),
              figure.image.height(), figure.panels.front().metres_per_pixel());
  return 0;
}

}  // namespace tsdf_mcl::cli
