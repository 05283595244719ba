#pragma once
// The fuzz targets, one per parser: each takes arbitrary bytes, hands them to the loader as a file (the loaders take
// paths, as the CLI gives them) and uses what loaded. A loader may reject any input with tsdf_mcl::Error but must
// never crash, hang, exceed its memory budget or throw anything else (an escaping exception aborts the run, which
// libFuzzer reports as a crash). fuzz_main.cpp makes one libFuzzer harness of each; the test suite runs every seed
// and every input that once crashed (fuzz/corpus/, fuzz/regressions/) through the same functions.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tsdf_mcl/io/cloud_io.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/imu.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/mapping/h5_import.hpp"
#include "tsdf_mcl/io/mesh.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros1_messages.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl::fuzz {

// A private scratch folder per process, in memory where /dev/shm exists; removed at exit.
inline const std::filesystem::path& scratch() {
  struct Folder {
    std::filesystem::path path;
    Folder() {
      const std::filesystem::path base = std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
      path = base / ("tsdf-mcl-fuzz-" + std::to_string(::getpid()));
      std::filesystem::create_directories(path);
    }
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  };
  static const Folder folder;
  return folder.path;
}

inline void write_file(const std::filesystem::path& file, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

// The bytes as scratch()/NAME; returns the path.
inline std::filesystem::path as_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path file = scratch() / name;
  write_file(file, data, size);
  return file;
}

// Runs `load`, accepting tsdf_mcl::Error as the answer to bad input.
template <typename Load>
void expect_no_crash(Load&& load) {
  try {
    load();
  } catch (const Error&) {
  }
}

// The .tsdf map file, then lookups inside, at the edges of and far outside the box: indices must stay within int
// arithmetic whatever the header said.
inline void map_file(const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] {
    const TsdfMap map = load_map(as_file("map.tsdf", data, size));
    map.stats();
    for (const Eigen::Vector3f& p :
         {Eigen::Vector3f(map.world_min()), Eigen::Vector3f(map.world_max()),
          Eigen::Vector3f(0.5f * (map.world_min() + map.world_max())), Eigen::Vector3f(1e30f, -1e30f, 3e9f)}) {
      map.nearest(p);
      map.trilinear(p);
    }
  });
}

// The reference implementation's HDF5 maps, within a 64 MiB budget.
inline void h5_import(const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] { import_reference_h5(as_file("map.h5", data, size), 0.6f, std::uint64_t{64} << 20); });
}

// STL, PLY and OBJ (the first byte picks), then a map of what loaded within a 4 MiB budget: tiny meshes with far
// vertices must end at the budget, not in gigabytes. The builder visits every block of a triangle's box within the
// budget's box, so the budget also bounds the time: at 32 MiB a 12-triangle STL 16 km wide took 90 s under ASan
// (past libFuzzer's 20 s timeout) without using more memory.
inline void mesh(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  static const char* const kNames[] = {"mesh.stl", "mesh.ply", "mesh.obj"};
  expect_no_crash([&] {
    const TriangleMesh mesh = load_mesh(as_file(kNames[data[0] % 3], data + 1, size - 1));
    MeshMapOptions options;
    options.voxel_size = 0.25f;
    options.truncation = 0.5f;
    options.margin = 0.5f;
    options.max_memory_bytes = std::uint64_t{4} << 20;
    build_map_from_mesh(mesh, options);
  });
}

// Map clouds, .pcd and .ply (the first byte picks), then a map of what loaded within a 32 MiB budget, without and with
// a short trajectory (the second byte picks).
inline void cloud(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return;
  static const char* const kNames[] = {"cloud.pcd", "cloud.ply"};
  expect_no_crash([&] {
    CloudReader reader(as_file(kNames[data[0] % 2], data + 2, size - 2), std::uint64_t{16} << 20);
    CloudMapOptions options;
    options.voxel_size = 0.25f;
    options.truncation = 0.5f;
    options.margin = 0.5f;
    options.max_memory_bytes = std::uint64_t{32} << 20;
    if (data[1] % 2)
      options.trajectory = {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(1, 0, 1), Eigen::Vector3f(1e30f, 0, 0)};
    build_map_from_cloud(reader, options);
  });
}

// Scan files, .pcd and KITTI .bin (the first byte picks), read as a one-scan dataset's scan.
inline void scan(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  static const char* const kNames[] = {"000000.pcd", "000000.bin"};
  const std::filesystem::path dir = scratch() / "scan";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "scans");
  std::ofstream(dir / "times.txt") << "0\n";
  write_file(dir / "scans" / kNames[data[0] % 2], data + 1, size - 1);
  expect_no_crash([&] { Dataset::open(dir).load_scan(0); });
}

// A dataset's text files (times.txt, poses.txt and odom.txt, imu.txt) and TUM trajectories (the first byte picks).
inline void text(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const std::uint8_t* body = data + 1;
  const std::size_t length = size - 1;
  expect_no_crash([&] {
    switch (data[0] % 4) {
      case 0: {
        // Dataset::open reads times.txt first; with one scan file a one-line file is a complete dataset.
        const std::filesystem::path dir = scratch() / "times";
        std::filesystem::create_directories(dir / "scans");
        std::ofstream(dir / "scans" / "000000.bin") << std::string(16, '\0');
        write_file(dir / "times.txt", body, length);
        Dataset::open(dir);
        break;
      }
      case 1:
        read_kitti_poses(as_file("poses.txt", body, length));
        break;
      case 2:
        read_imu(as_file("imu.txt", body, length));
        break;
      default:
        read_tum(as_file("trajectory.tum", body, length));
        break;
    }
  });
}

// YAML / JSON parameter files (localize --config).
inline void config(const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] { read_parameter_file(as_file("config.yaml", data, size).string()); });
}

// Particle snapshots (render --particles).
inline void snapshot(const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] { read_particle_snapshot(as_file("particles.bin", data, size)); });
}

// A serialized sensor_msgs/PointCloud2 (as a bag holds it), decoded as the bag reader does: the message, then the
// points its layout describes. Nothing here needs ROS.
inline void pointcloud2(const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] {
    const ros1::PointCloud2Message m = ros1::decode_pointcloud2_message(data, size, "fuzz");
    PointCloud2Stats stats;
    const PointCloud cloud = decode_pointcloud2(m.layout, data + m.data_offset, m.data_size, &stats, "fuzz");
    if (cloud.size() + stats.dropped_non_finite != stats.points) std::abort();
  });
}

// The other messages a bag dataset reads (the first byte picks): tf2_msgs/TFMessage, nav_msgs/Odometry,
// geometry_msgs/PoseStamped, sensor_msgs/Imu.
inline void ros_messages(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const std::uint8_t* body = data + 1;
  const std::size_t length = size - 1;
  expect_no_crash([&] {
    switch (data[0] % 4) {
      case 0:
        ros1::decode_tf_message(body, length, "fuzz");
        break;
      case 1:
        ros1::decode_odometry(body, length, "fuzz");
        break;
      case 2:
        ros1::decode_pose_stamped(body, length, "fuzz");
        break;
      default:
        ros1::decode_imu(body, length, "fuzz");
        break;
    }
  });
}

// The same ROS 2 messages in CDR (the first byte picks): sensor_msgs/PointCloud2 (then its points),
// tf2_msgs/TFMessage, nav_msgs/Odometry, geometry_msgs/PoseStamped and PoseWithCovarianceStamped, sensor_msgs/Imu.
inline void cdr(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const std::uint8_t* body = data + 1;
  const std::size_t length = size - 1;
  expect_no_crash([&] {
    switch (data[0] % 6) {
      case 0: {
        const msg::PointCloud2Message m = ros2::decode_pointcloud2_message(body, length, "fuzz");
        PointCloud2Stats stats;
        const PointCloud cloud = decode_pointcloud2(m.layout, body + m.data_offset, m.data_size, &stats, "fuzz");
        if (cloud.size() + stats.dropped_non_finite != stats.points) std::abort();
        break;
      }
      case 1:
        ros2::decode_tf_message(body, length, "fuzz");
        break;
      case 2:
        ros2::decode_odometry(body, length, "fuzz");
        break;
      case 3:
        ros2::decode_pose_stamped(body, length, "fuzz");
        break;
      case 4:
        ros2::decode_pose_with_covariance_stamped(body, length, "fuzz");
        break;
      default:
        ros2::decode_imu(body, length, "fuzz");
        break;
    }
  });
}

// A whole bag file opened as a dataset (scans on /points, odometry from tf, ground truth on /ground_truth, IMU on
// /imu), then every scan loaded.
inline void open_bag_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
  expect_no_crash([&] {
    BagOptions options;
    options.points_topic = "/points";
    options.ground_truth_topic = "/ground_truth";
    options.imu_topic = "/imu";
    const Dataset ds = Dataset::open_bag(as_file(name, data, size), options);
    for (std::size_t i = 0; i < ds.size(); ++i) ds.load_scan(i);
  });
}

// An MCAP file (rosbag2's storage since Iron): the container (chunks, compression, CRCs, a summary or none), the
// CDR messages in it and the dataset built from them.
inline void mcap(const std::uint8_t* data, std::size_t size) { open_bag_file("run.mcap", data, size); }

#if TSDF_MCL_HAVE_ROSBAG
// A ROS 1 bag. rosbag_storage runs in a child process there; a crash in it must be an Error.
inline void bag(const std::uint8_t* data, std::size_t size) { open_bag_file("run.bag", data, size); }
#endif

// Name (the folder of its seeds and regressions) -> target.
struct Target {
  const char* name;
  void (*run)(const std::uint8_t*, std::size_t);
};
inline constexpr Target kTargets[] = {
    {"map_file", map_file},
    {"h5_import", h5_import},
    {"mesh", mesh},
    {"scan", scan},
    {"text", text},
    {"config", config},
    {"snapshot", snapshot},
    {"cloud", cloud},
    {"pointcloud2", pointcloud2},
    {"ros_messages", ros_messages},
    {"cdr", cdr},
    {"mcap", mcap},
#if TSDF_MCL_HAVE_ROSBAG
    {"bag", bag},
#endif
};

}  // namespace tsdf_mcl::fuzz
