// tsdf-mcl export-cloud: a dataset's scans at their poses as one world-frame PCD, the map cloud a SLAM system writes
// (to try build-map --cloud on simulated or recorded data).
#include <cstdio>
#include <string>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/cloud_io.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::cli {

int run_export_cloud(int argc, char** argv) {
  Options o("export-cloud",
            "tsdf-mcl export-cloud --dataset DIR [--start S --stride K --count N] [--laser_min_range M "
            "--laser_max_range M] -o FILE.pcd",
            {
                {"dataset", "DIR", "", "dataset whose scans are placed at the poses of its poses.txt"},
                {"start", "S", "0", "first scan"},
                {"stride", "K", "1", "use every K-th scan"},
                {"count", "N", "0", "number of scans (0 = all remaining)"},
                {"laser_min_range", "M", "0.3", "ignore points closer to the sensor (m)"},
                {"laser_max_range", "M", "60", "ignore points farther from the sensor (m)"},
                {"output", "FILE", "", "binary PCD file to write (x y z float32, world frame)"},
            },
            argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  if (!o.positional().empty()) throw Error("unexpected argument '" + o.positional().front() + "'");
  if (!o.has("dataset")) throw Error("missing --dataset DIR");
  if (!o.has("output")) throw Error("missing -o FILE.pcd");
  const std::string output = o.text("output");
  check_output_file(output, "cloud");
  const Dataset dataset = Dataset::open(o.text("dataset"));
  const std::vector<std::size_t> scans =
      ScanSelection{o.count("start"), o.count("stride"), o.count("count")}.indices(dataset.size());
  if (scans.empty()) throw Error("the selection holds none of the " + std::to_string(dataset.size()) + " scans");
  const std::uint64_t points = write_dataset_cloud(dataset, scans, static_cast<float>(o.number("laser_min_range")),
                                                   static_cast<float>(o.number("laser_max_range")), output);
  std::fprintf(stderr, "export-cloud: wrote %s: %llu points from %zu scans\n", output.c_str(),
               static_cast<unsigned long long>(points), scans.size());
  return 0;
}

}  // namespace tsdf_mcl::cli
