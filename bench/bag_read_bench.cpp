// How fast the bag readers read (bench/rosbag2_readers.sh, docs/bags.md): writes a dataset folder as a bag of any
// format with BagWriter, and reads a bag as localize does (Dataset::open_bag, then every scan), one JSON line.
//
//   bag_read_bench write DATASET_DIR BAG [storage mcap|sqlite3] [compression none|zstd|lz4]
//   bag_read_bench read BAG [POINTS_TOPIC]
//   bag_read_bench ros1      -> 1 where the build reads (and writes) ROS 1 bags, else 0
//     -> {"bench":"bag_read","bag":...,"bytes":...,"scans":...,"points":...,"open_s":...,"load_s":...,
//         "cpu_s":...,"mb_per_s":...,"mb_per_cpu_s":...}
//     bytes: the bag's files; MB/s: bytes / (open + load) of wall-clock time, 1 MB = 10^6 bytes; cpu_s: the
//     process's user + system time for both (on a shared machine the wall clock also counts other processes' turns)
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace fs = std::filesystem;
using namespace tsdf_mcl;

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6; };
  return s(u.ru_utime) + s(u.ru_stime);
}

std::uint64_t bytes_of(const fs::path& path) {
  if (!fs::is_directory(path)) return fs::file_size(path);
  std::uint64_t n = 0;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(path)) {
    if (e.is_regular_file()) n += e.file_size();
  }
  return n;
}

int write(int argc, char** argv) {
  const Dataset ds = Dataset::open(argv[2]);
  BagWriterOptions o;
  if (argc > 4) o.storage = argv[4];
  if (argc > 5 && std::string(argv[5]) != "none") o.compression = argv[5];
  BagWriter bag(argv[3], o);
  for (std::size_t i = 0; i < ds.size(); ++i) {
    bag.add_scan(ds.time(i) + 1.0, ds.load_scan(i), nullptr,
                 ds.has_poses() ? std::optional<Pose>(ds.pose(i)) : std::nullopt,
                 ds.has_odometry() ? std::optional<Pose>(ds.odometry(i)) : std::nullopt);
  }
  bag.close();
  std::fprintf(stderr, "bag_read_bench: wrote %s (%zu scans, %.1f MB)\n", argv[3], ds.size(),
               static_cast<double>(bytes_of(argv[3])) / 1e6);
  return 0;
}

int read(int argc, char** argv) {
  BagOptions o;
  o.points_topic = argc > 3 ? argv[3] : "/points";
  const double cpu_start = cpu_seconds();
  const auto start = std::chrono::steady_clock::now();
  const Dataset ds = Dataset::open_bag(argv[2], o);
  const double open_s = seconds_since(start);
  const auto loading = std::chrono::steady_clock::now();
  std::size_t points = 0;
  for (std::size_t i = 0; i < ds.size(); ++i) points += ds.load_scan(i).size();
  const double load_s = seconds_since(loading);
  const double cpu_s = cpu_seconds() - cpu_start;
  const std::uint64_t bytes = bytes_of(argv[2]);
  const double mb = static_cast<double>(bytes) / 1e6;
  nlohmann::json line = {{"bench", "bag_read"}, {"bag", argv[2]}, {"bytes", bytes}, {"scans", ds.size()}};
  line["points"] = points;
  line["open_s"] = open_s;
  line["load_s"] = load_s;
  line["cpu_s"] = cpu_s;
  line["mb_per_s"] = mb / (open_s + load_s);
  line["mb_per_cpu_s"] = mb / cpu_s;
  std::printf("%s\n", line.dump().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "write" && argc >= 4) return write(argc, argv);
    if (mode == "read" && argc >= 3) return read(argc, argv);
    if (mode == "ros1") return std::printf("%d\n", Dataset::ros1_bag_support() ? 1 : 0) < 0;
    std::fprintf(stderr,
                 "usage: bag_read_bench write DATASET_DIR BAG [mcap|sqlite3] [none|zstd|lz4]\n"
                 "       bag_read_bench read BAG [POINTS_TOPIC]\n       bag_read_bench ros1\n");
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "bag_read_bench: error: %s\n", e.what());
    return 1;
  }
}
