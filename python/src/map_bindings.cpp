// Map (a TsdfMap shared with the localizers built on it) and the three map builders.
#include <pybind11/stl.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/io/mesh.hpp"

namespace tsdf_mcl::python {
namespace {

namespace fs = std::filesystem;
using MapPtr = std::shared_ptr<TsdfMap>;

std::uint64_t memory_bytes(double mib) {
  if (!(mib > 0.0) || mib > 1e9) throw BadArgument("max_memory_mib must be a positive number of MiB");
  return static_cast<std::uint64_t>(mib * 1048576.0);
}

void check_geometry(float voxel_size, float truncation) {
  if (!(voxel_size > 0.0f) || !std::isfinite(voxel_size)) throw BadArgument("voxel_size must be positive");
  if (!(truncation > 0.0f) || !std::isfinite(truncation)) throw BadArgument("truncation must be positive");
}

py::array_t<float> distance(const TsdfMap& map, const py::handle& points, const std::string& interpolation) {
  if (interpolation != "nearest" && interpolation != "trilinear") {
    throw BadArgument("interpolation must be nearest or trilinear, not '" + interpolation + "'");
  }
  const std::vector<Eigen::Vector3f> p = points_from(points, "points", true);
  py::array_t<float> out(static_cast<py::ssize_t>(p.size()));
  float* d = out.mutable_data();
  const bool trilinear = interpolation == "trilinear";
  {
    py::gil_scoped_release release;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const TsdfMap::Sample s = trilinear ? map.trilinear(p[i]) : map.nearest(p[i]);
      d[i] = s.known ? s.distance : std::numeric_limits<float>::quiet_NaN();
    }
  }
  return out;
}

py::dict info(const TsdfMap& map) {
  const TsdfMap::Stats s = map.stats();
  const Eigen::Vector3f lo = map.world_min(), hi = map.world_max();
  py::dict d;
  d["voxel_size"] = map.voxel_size();
  d["truncation"] = map.truncation();
  d["world_min"] = py::make_tuple(lo.x(), lo.y(), lo.z());
  d["world_max"] = py::make_tuple(hi.x(), hi.y(), hi.z());
  d["dims_blocks"] = py::make_tuple(map.dims_blocks().x(), map.dims_blocks().y(), map.dims_blocks().z());
  d["allocated_blocks"] = s.allocated_blocks;
  d["free_blocks"] = s.free_blocks;
  d["known_voxels"] = s.known_voxels;
  d["free_voxels"] = s.free_voxels;
  d["memory_bytes"] = s.memory_bytes;
  return d;
}

// A scratch dataset folder for scans given as arrays (build_map_from_scans reads a Dataset), removed on scope exit.
class ScratchDataset {
 public:
  ScratchDataset() {
    std::string pattern = (fs::temp_directory_path() / "tsdf_mcl_scans_XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw Error("cannot create a scratch folder in " + fs::temp_directory_path().string());
    dir_ = pattern;
  }
  ~ScratchDataset() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  ScratchDataset(const ScratchDataset&) = delete;
  ScratchDataset& operator=(const ScratchDataset&) = delete;
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

MapPtr from_scan_arrays(const py::sequence& scans, const py::handle& poses, const ScanMapOptions& options) {
  const std::vector<Pose> world_T_sensor = poses_from(poses, "poses");
  if (world_T_sensor.size() != scans.size()) {
    throw BadArgument("poses holds " + std::to_string(world_T_sensor.size()) + " poses for " +
                      std::to_string(scans.size()) + " scans");
  }
  if (scans.size() == 0) throw BadArgument("scans is empty");
  std::vector<PointCloud> clouds(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const std::string name = "scans[" + std::to_string(i) + "]";
    clouds[i].points = points_from(scans[i], name.c_str());
  }
  py::gil_scoped_release release;
  ScratchDataset scratch;
  {
    DatasetWriter writer(scratch.dir() / "scans_dataset");
    for (std::size_t i = 0; i < clouds.size(); ++i)
      writer.add(static_cast<double>(i), clouds[i], world_T_sensor[i], {});
    writer.close();
  }
  const Dataset dataset = Dataset::open(scratch.dir() / "scans_dataset");
  std::vector<std::size_t> all(dataset.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  return std::make_shared<TsdfMap>(build_map_from_scans(dataset, all, options));
}

}  // namespace

// Defined in dataset_bindings.cpp: the Dataset behind a Python Dataset object (nullptr for another object).
const Dataset* dataset_of(const py::handle& obj, std::vector<std::size_t>* scans);

namespace {

// The builders, as tsdf-mcl build-map --mesh, --cloud and --dataset; each releases the GIL while it builds.
MapPtr map_from_mesh(const std::string& path, float voxel_size, float truncation, float margin, bool fill_free_space,
                     double max_memory_mib) {
  check_geometry(voxel_size, truncation);
  MeshMapOptions o;
  o.voxel_size = voxel_size;
  o.truncation = truncation;
  o.margin = margin;
  o.fill_free_space = fill_free_space;
  o.max_memory_bytes = memory_bytes(max_memory_mib);
  py::gil_scoped_release release;
  return std::make_shared<TsdfMap>(build_map_from_mesh(load_mesh(path), o));
}

MapPtr map_from_cloud(const py::handle& points, float voxel_size, float truncation, float margin,
                      const py::object& trajectory, float max_range, bool fill_free_space, double max_memory_mib) {
  check_geometry(voxel_size, truncation);
  CloudMapOptions o;
  o.voxel_size = voxel_size;
  o.truncation = truncation;
  o.margin = margin;
  o.max_range = max_range;
  o.fill_free_space = fill_free_space;
  o.max_memory_bytes = memory_bytes(max_memory_mib);
  if (!trajectory.is_none()) o.trajectory = positions_from(trajectory, "trajectory");
  const std::vector<Eigen::Vector3f> p = points_from(points, "points");
  py::gil_scoped_release release;
  return std::make_shared<TsdfMap>(build_map_from_cloud(p, o));
}

MapPtr map_from_scans(const py::object& scans, const py::object& poses, float voxel_size, float truncation,
                      float min_range, float max_range, float margin, double max_memory_mib) {
  check_geometry(voxel_size, truncation);
  ScanMapOptions o;
  o.voxel_size = voxel_size;
  o.truncation = truncation;
  o.min_range = min_range;
  o.max_range = max_range;
  o.margin = margin;
  o.max_memory_bytes = memory_bytes(max_memory_mib);
  std::vector<std::size_t> selected;
  if (const Dataset* dataset = dataset_of(scans, &selected)) {
    if (!poses.is_none()) throw BadArgument("poses: a Dataset brings its own (poses.txt)");
    if (!dataset->has_poses()) throw Error(dataset->missing_poses());
    py::gil_scoped_release release;
    return std::make_shared<TsdfMap>(build_map_from_scans(*dataset, selected, o));
  }
  if (!py::isinstance<py::sequence>(scans) || py::isinstance<py::array>(scans)) {
    throw BadArgument("scans must be a Dataset or a list of float32 (N, 3) arrays");
  }
  if (poses.is_none()) throw BadArgument("poses (world_T_sensor, shape (N, 4, 4)) is required with scan arrays");
  return from_scan_arrays(py::reinterpret_borrow<py::sequence>(scans), poses, o);
}

}  // namespace

void register_map(py::module_& m) {
  py::class_<TsdfMap, MapPtr>(m, "Map", "A TSDF map (the .tsdf file of tsdf-mcl build-map)")
      .def_static(
          "load",
          [](const std::string& path) {
            py::gil_scoped_release release;
            return std::make_shared<TsdfMap>(load_map(path));
          },
          py::arg("path"), "Loads a .tsdf map file (tsdf_mcl.Error for a missing, corrupt or wrong-version file).")
      .def(
          "save",
          [](const TsdfMap& map, const std::string& path) {
            py::gil_scoped_release release;
            save_map(map, path);
          },
          py::arg("path"), "Writes the map as a .tsdf file.")
      .def("info", &info, "Geometry and occupancy: voxel_size, truncation, world_min/max, blocks, voxels, memory.")
      .def("distance", &distance, py::arg("points"), py::arg("interpolation") = "nearest",
           "TSDF lookup of a float32 (N, 3) or (N, 4) array of world points: (N,) float32 signed distances in metres, "
           "NaN where the map is unknown. interpolation: nearest (the filter's default) or trilinear.")
      .def_property_readonly("voxel_size", &TsdfMap::voxel_size)
      .def_property_readonly("truncation", &TsdfMap::truncation)
      .def("__repr__", [](const TsdfMap& map) {
        const Eigen::Vector3f lo = map.world_min(), hi = map.world_max();
        char buf[160];
        std::snprintf(buf, sizeof(buf), "<tsdf_mcl.Map voxel %.3f m, %.1f x %.1f x %.1f m, %zu blocks>",
                      static_cast<double>(map.voxel_size()), static_cast<double>(hi.x() - lo.x()),
                      static_cast<double>(hi.y() - lo.y()), static_cast<double>(hi.z() - lo.z()), map.block_count());
        return std::string(buf);
      });

  m.def("build_map_from_mesh", &map_from_mesh, py::arg("path"), py::arg("voxel_size") = kDefaultVoxelSize,
        py::arg("truncation") = kDefaultTruncation, py::arg("margin") = 1.0f, py::arg("fill_free_space") = true,
        py::arg("max_memory_mib") = static_cast<double>(limits::kDefaultBuildMemoryMiB),
        "A map from a triangle mesh file (STL, PLY, OBJ), as tsdf-mcl build-map --mesh.");
  m.def("build_map_from_cloud", &map_from_cloud, py::arg("points"), py::arg("voxel_size") = kDefaultVoxelSize,
        py::arg("truncation") = kDefaultTruncation, py::arg("margin") = 1.0f, py::arg("trajectory") = py::none(),
        py::arg("max_range") = 60.0f, py::arg("fill_free_space") = true,
        py::arg("max_memory_mib") = static_cast<double>(limits::kDefaultBuildMemoryMiB),
        "A map from a world-frame float32 (N, 3) point cloud, as tsdf-mcl build-map --cloud; trajectory: the mapping "
        "run's sensor positions (M, 3), if known.");
  m.def("build_map_from_scans", &map_from_scans, py::arg("scans"), py::arg("poses") = py::none(),
        py::arg("voxel_size") = kDefaultVoxelSize, py::arg("truncation") = kDefaultTruncation,
        py::arg("min_range") = 0.3f, py::arg("max_range") = 60.0f, py::arg("margin") = 1.0f,
        py::arg("max_memory_mib") = static_cast<double>(limits::kDefaultBuildMemoryMiB),
        "A map by TSDF integration of registered scans, as tsdf-mcl build-map --dataset: a Dataset (its poses.txt), "
        "or a list of sensor-frame float32 (N, 3) arrays with their poses, shape (N, 4, 4) world_T_sensor.");
}

}  // namespace tsdf_mcl::python
