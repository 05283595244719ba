// Datasets (a folder or a ROS 1 bag) as Python iterables of (stamp, points, odom), and the trajectory metrics of
// tsdf-mcl evaluate.
#include <pybind11/stl.h>

#include <memory>
#include <string>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/eval/trajectory_metrics.hpp"

namespace tsdf_mcl::python {

// A dataset with the scans selected from it (start, stride, count).
struct PyDataset {
  std::shared_ptr<const Dataset> dataset;
  std::vector<std::size_t> indices;
};

namespace {

constexpr double kDeg = 57.29577951308232;

// (stamp, points (N, 3) float32, odom 4x4 or None) of the k-th selected scan.
py::tuple scan_tuple(const PyDataset& d, std::size_t k) {
  const std::size_t i = d.indices.at(k);
  PointCloud cloud;
  {
    py::gil_scoped_release release;
    cloud = d.dataset->load_scan(i);
  }
  const py::object odom = d.dataset->has_odometry() ? py::object(matrix_array(d.dataset->odometry(i))) : py::none();
  return py::make_tuple(d.dataset->time(i), points_array(std::move(cloud.points)), odom);
}

struct DatasetIterator {
  std::shared_ptr<const PyDataset> source;
  std::size_t next = 0;
};

PyDataset select(std::shared_ptr<const Dataset> dataset, std::size_t start, std::size_t stride, std::size_t count) {
  if (stride == 0) throw BadArgument("stride must be at least 1");
  ScanSelection s;
  s.start = start;
  s.stride = stride;
  s.count = count;
  PyDataset d;
  d.indices = s.indices(dataset->size());
  d.dataset = std::move(dataset);
  return d;
}

py::array_t<double> selected_times(const PyDataset& d) {
  py::array_t<double> t(static_cast<py::ssize_t>(d.indices.size()));
  for (std::size_t k = 0; k < d.indices.size(); ++k)
    t.mutable_at(static_cast<py::ssize_t>(k)) = d.dataset->time(d.indices[k]);
  return t;
}

py::object selected_poses(const PyDataset& d, bool odometry) {
  if (odometry ? !d.dataset->has_odometry() : !d.dataset->has_poses()) return py::none();
  std::vector<Pose> poses;
  for (const std::size_t i : d.indices) poses.push_back(odometry ? d.dataset->odometry(i) : d.dataset->pose(i));
  return poses_array(poses);
}

py::array_t<double> imu_array(const Dataset& dataset) {
  const std::vector<ImuSample> imu = dataset.imu();
  py::array_t<double> a({static_cast<py::ssize_t>(imu.size()), py::ssize_t{4}});
  auto w = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const auto r = static_cast<py::ssize_t>(i);
    w(r, 0) = imu[i].time;
    for (int c = 0; c < 3; ++c) w(r, c + 1) = imu[i].acceleration[c];
  }
  return a;
}

py::dict metrics_dict(const TrajectoryMetrics& m, const MetricsOptions& mo) {
  py::dict j;
  j["scans"] = m.errors.size();
  j["converged"] = m.converged;
  j["localized_fraction"] = m.localized_fraction;
  j["thresholds"] = py::dict(py::arg("translation_m") = mo.max_translation_error,
                             py::arg("rotation_deg") = mo.max_rotation_error * kDeg);
  j["convergence"] = py::none();
  j["after_convergence"] = py::none();
  if (m.converged) {
    const PoseError& first = m.errors[m.convergence_index];
    j["convergence"] = py::dict(py::arg("estimate_index") = m.convergence_index, py::arg("scan") = first.truth_index,
                                py::arg("time_s") = m.convergence_time);
    j["after_convergence"] = py::dict(py::arg("scans") = m.converged_count, py::arg("ate_rmse_m") = m.ate_rmse,
                                      py::arg("rotation_rmse_deg") = m.rotation_rmse * kDeg,
                                      py::arg("max_translation_error_m") = m.max_translation_error,
                                      py::arg("max_rotation_error_deg") = m.max_rotation_error * kDeg);
  }
  j["false_convergence"] = py::none();
  if (m.has_claims) {
    j["false_convergence"] = py::dict(
        py::arg("claimed_converged_scans") = m.claimed_converged, py::arg("false_claims") = m.false_convergence,
        py::arg("first_false_scan") =
            m.false_convergence > 0 ? py::cast(m.errors[m.first_false_index].truth_index) : py::none(),
        py::arg("first_false_time_s") = m.false_convergence > 0 ? py::cast(m.first_false_time) : py::none(),
        py::arg("thresholds") = py::dict(py::arg("translation_m") = mo.false_convergence_translation,
                                         py::arg("rotation_deg") = mo.false_convergence_rotation * kDeg));
  }
  // Per estimate, for plots: translation error (world frame, estimate - truth), its norm, rotation error (deg).
  const auto n = static_cast<py::ssize_t>(m.errors.size());
  py::array_t<double> translation({n, py::ssize_t{3}}), norm(n), rotation(n);
  py::array_t<bool> localized(n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const PoseError& e = m.errors[static_cast<std::size_t>(i)];
    for (int a = 0; a < 3; ++a) translation.mutable_at(i, a) = e.translation[a];
    norm.mutable_at(i) = e.translation_norm;
    rotation.mutable_at(i) = e.rotation * kDeg;
    localized.mutable_at(i) = e.localized;
  }
  j["errors"] = py::dict(py::arg("translation_m") = translation, py::arg("translation_norm_m") = norm,
                         py::arg("rotation_deg") = rotation, py::arg("localized") = localized);
  return j;
}

py::dict evaluate(const py::handle& times, const py::handle& poses, const py::handle& ground_truth,
                  const py::object& converged, double max_translation_error, double max_rotation_error_deg,
                  double time_tolerance, double false_convergence_translation, double false_convergence_rotation_deg) {
  const std::vector<double> t = values_from(times, "times");
  const std::vector<Pose> p = poses_from(poses, "poses");
  if (t.size() != p.size()) {
    throw BadArgument("times holds " + std::to_string(t.size()) + " stamps for " + std::to_string(p.size()) + " poses");
  }
  if (t.empty()) throw BadArgument("the estimate holds no pose");
  std::vector<double> truth_times;
  std::vector<Pose> truth_poses;
  if (py::isinstance<PyDataset>(ground_truth)) {
    const PyDataset& d = ground_truth.cast<const PyDataset&>();
    if (!d.dataset->has_poses()) throw Error(d.dataset->missing_poses() + " (ground truth)");
    truth_times = d.dataset->times();
    truth_poses = d.dataset->poses();
  } else if (py::isinstance<py::tuple>(ground_truth) && py::len(ground_truth) == 2) {
    const auto gt = py::reinterpret_borrow<py::tuple>(ground_truth);
    truth_times = values_from(gt[0], "ground_truth times");
    truth_poses = poses_from(gt[1], "ground_truth poses");
    if (truth_times.size() != truth_poses.size() || truth_times.empty()) {
      throw BadArgument("ground_truth must hold as many stamps as poses, at least one");
    }
  } else {
    throw BadArgument("ground_truth must be a Dataset with poses or a tuple (times, poses)");
  }
  MetricsOptions mo;
  mo.max_translation_error = max_translation_error;
  mo.max_rotation_error = max_rotation_error_deg / kDeg;
  mo.time_tolerance = time_tolerance;
  mo.false_convergence_translation = false_convergence_translation;
  mo.false_convergence_rotation = false_convergence_rotation_deg / kDeg;
  if (!(mo.max_translation_error > 0.0) || !(mo.max_rotation_error > 0.0) || !(mo.time_tolerance >= 0.0) ||
      !(mo.false_convergence_translation > 0.0) || !(mo.false_convergence_rotation > 0.0)) {
    throw BadArgument("thresholds must be positive and the time tolerance non-negative");
  }
  std::vector<bool> claims;
  if (!converged.is_none()) {
    for (const py::handle c : converged) claims.push_back(py::cast<bool>(c));
    if (claims.size() != t.size()) {
      throw BadArgument("converged holds " + std::to_string(claims.size()) + " flags for " + std::to_string(t.size()) +
                        " estimates");
    }
  }
  std::vector<StampedPose> estimate(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) estimate[i] = {t[i], p[i]};
  const TrajectoryMetrics m =
      evaluate_trajectory(estimate, truth_times, truth_poses, mo, converged.is_none() ? nullptr : &claims);
  return metrics_dict(m, mo);
}

// The Dataset class and its iterator: len, indexing, iteration, and the selected scans' arrays.
void register_dataset_classes(py::module_& m) {
  py::class_<DatasetIterator>(m, "_DatasetIterator")
      .def("__iter__", [](DatasetIterator& it) -> DatasetIterator& { return it; })
      .def("__next__", [](DatasetIterator& it) {
        if (it.next >= it.source->indices.size()) throw py::stop_iteration();
        return scan_tuple(*it.source, it.next++);
      });

  py::class_<PyDataset, std::shared_ptr<PyDataset>>(
      m, "Dataset", "The selected scans of a dataset folder or a ROS 1 bag; iterating yields (stamp, points, odom).")
      .def("__len__", [](const PyDataset& d) { return d.indices.size(); })
      .def("__getitem__",
           [](const PyDataset& d, long long k) {
             const auto n = static_cast<long long>(d.indices.size());
             if (k < 0) k += n;
             if (k < 0 || k >= n) throw py::index_error("scan " + std::to_string(k) + " of " + std::to_string(n));
             return scan_tuple(d, static_cast<std::size_t>(k));
           })
      .def("__iter__",
           [](const std::shared_ptr<PyDataset>& d) {
             return DatasetIterator{d, 0};
           })
      .def_property_readonly(
          "indices", [](const PyDataset& d) { return d.indices; }, "each selected scan's index in the whole dataset")
      .def_property_readonly("times", &selected_times, "stamps of the selected scans (s)")
      .def_property_readonly(
          "poses", [](const PyDataset& d) { return selected_poses(d, false); },
          "ground truth world_T_sensor, (N, 4, 4), or None")
      .def_property_readonly(
          "odometry", [](const PyDataset& d) { return selected_poses(d, true); },
          "odometry odom_T_sensor, (N, 4, 4), or None")
      .def_property_readonly(
          "imu", [](const PyDataset& d) { return imu_array(*d.dataset); },
          "IMU samples (M, 4): t, specific force x y z in the sensor frame (m/s^2)")
      .def_property_readonly("path", [](const PyDataset& d) { return d.dataset->dir().string(); })
      .def_property_readonly("summary", [](const PyDataset& d) { return d.dataset->summary(); });
}

// A bag (ROS 1, or a rosbag2 folder, .db3 or .mcap) as a dataset; the GIL is released while the bag is indexed.
PyDataset read_bag(const std::string& path, const std::string& points_topic, const std::string& odom_frame,
                   const std::string& base_frame, const std::string& odom_topic, const std::string& ground_truth_topic,
                   const std::string& imu_topic, std::size_t start, std::size_t stride, std::size_t count) {
  BagOptions o;
  o.points_topic = points_topic;
  o.odom_frame = odom_frame;
  o.base_frame = base_frame;
  o.odom_topic = odom_topic;
  o.ground_truth_topic = ground_truth_topic;
  o.imu_topic = imu_topic;
  std::shared_ptr<const Dataset> dataset;
  {
    py::gil_scoped_release release;
    dataset = std::make_shared<const Dataset>(Dataset::open_bag(path, o));
  }
  return select(std::move(dataset), start, stride, count);
}

}  // namespace

const Dataset* dataset_of(const py::handle& obj, std::vector<std::size_t>* scans) {
  if (!py::isinstance<PyDataset>(obj)) return nullptr;
  const PyDataset& d = obj.cast<const PyDataset&>();
  if (scans) *scans = d.indices;
  return d.dataset.get();
}

void register_dataset(py::module_& m) {
  register_dataset_classes(m);

  m.def(
      "read_dataset",
      [](const std::string& dir, std::size_t start, std::size_t stride, std::size_t count) {
        auto dataset = std::make_shared<const Dataset>(Dataset::open(dir));
        return select(std::move(dataset), start, stride, count);
      },
      py::arg("dir"), py::arg("start") = 0, py::arg("stride") = 1, py::arg("count") = 0,
      "A dataset folder (scans/, times.txt, optional poses.txt, odom.txt, imu.txt); start/stride/count as in "
      "tsdf-mcl localize (count 0 = all).");

  m.def("read_bag", &read_bag, py::arg("path"), py::arg("points_topic"), py::arg("odom_frame") = "odom",
        py::arg("base_frame") = "base_link", py::arg("odom_topic") = "", py::arg("ground_truth_topic") = "",
        py::arg("imu_topic") = "", py::arg("start") = 0, py::arg("stride") = 1, py::arg("count") = 0,
        "A bag as a dataset (docs/bags.md): ROS 1, or ROS 2 (a rosbag2 folder, .db3 or .mcap file); the PointCloud2 "
        "scans of points_topic, odometry from tf or odom_topic, ground truth and IMU from their topics.");
  m.attr("ros1_bag_support") = Dataset::ros1_bag_support();

  m.def("evaluate", &evaluate, py::arg("times"), py::arg("poses"), py::arg("ground_truth"),
        py::arg("converged") = py::none(), py::arg("max_translation_error") = 0.3,
        py::arg("max_rotation_error_deg") = 5.0, py::arg("time_tolerance") = 0.02,
        py::arg("false_convergence_translation") = 1.0, py::arg("false_convergence_rotation_deg") = 10.0,
        "The metrics of tsdf-mcl evaluate for an estimated trajectory (times (N,), poses (N, 4, 4) world_T_sensor) "
        "against ground_truth (a Dataset with poses, or a tuple (times, poses)); converged: the localizer's flags per "
        "estimate, for the false-convergence count. Returns the CLI's JSON as a dict, plus per-estimate 'errors'.");
}

}  // namespace tsdf_mcl::python
