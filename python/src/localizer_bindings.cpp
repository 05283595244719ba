// Localizer: the library's streaming Localizer on a Map, fed numpy scans; Result, Place.
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "arguments.hpp"
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "parameters.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/localizer/map_extent_checks.hpp"

namespace tsdf_mcl::python {
namespace {

struct PyPlace {
  Pose pose = Pose::Identity();
  Matrix6d covariance = Matrix6d::Zero();
  double weight = 0.0, std_position = 0.0, std_rotation = 0.0, inlier_ratio = 0.0;
  std::size_t particles = 0;
};

// What one process() call did, copied out of the ScanRecord (valid only until the next scan).
struct PyResult {
  double time = 0.0;
  std::uint64_t index = 0;
  std::string state;
  std::string reason;     // why the state is what it is
  double coverage = 0.0;  // share of the scan's points with map evidence at the estimate
  bool updated = false, resampled = false, converged = false;
  PyPlace estimate;
  std::vector<PyPlace> places;
  std::size_t particles = 0, next_particles = 0, injected = 0;
  double ess = 0.0;
  std::map<std::string, std::size_t> points;
  std::map<std::string, double> timings;
};

PyPlace place_of(const Place& h) {
  return {h.pose, h.covariance, h.weight, h.std_position, h.std_rotation, h.inlier_ratio, h.particles};
}

PyResult result_of(const ScanRecord& r, double process_ms) {
  const FilterStep& s = r.step;
  const PoseEstimate& e = s.estimate;
  PyResult out;
  out.time = r.time;
  out.index = r.index;
  out.state = to_string(s.state);  // the filter's own classification (track_state.hpp)
  out.reason = to_string(s.reason);
  out.coverage = e.coverage;
  out.updated = s.updated;
  out.resampled = s.resampled;
  out.converged = e.converged;
  out.estimate = {e.pose,         e.covariance,   e.place_weight,   e.std_position,
                  e.std_rotation, e.inlier_ratio, e.place_particles};
  for (const Place& h : e.places) out.places.push_back(place_of(h));
  out.particles = s.particles;
  out.next_particles = s.next_particles;
  out.injected = s.injected;
  out.ess = s.ess;
  out.points = {{"input", r.points.input},
                {"in_range", r.points.in_range},
                {"thinned", r.points.thinned},
                {"used", r.points.output},
                {"track_evidence", s.weighed_points}};  // report.json's, 0 for its null (every point)
  const StepTimings& t = s.timings;
  out.timings = {
      {"preprocess_ms", r.preprocess_ms}, {"motion_ms", t.motion_ms},         {"upload_ms", t.upload_ms},
      {"weight_ms", t.weight_ms},         {"weight_gpu_ms", t.weight_gpu_ms}, {"reduce_gpu_ms", t.reduce_gpu_ms},
      {"walls_ms", t.walls_ms},           {"own_points_ms", t.own_points_ms}, {"tempering_ms", t.tempering_ms},
      {"places_ms", t.places_ms},         {"ledger_ms", t.ledger_ms},         {"decision_ms", t.decision_ms},
      {"resample_ms", t.resample_ms},     {"update_ms", t.total_ms},          {"process_ms", process_ms}};
  return out;
}

// The library's checks of map_extent_checks.hpp (Error) as ValueError naming the Python argument.
template <typename Check>
void as_bad_argument(Check check) {
  try {
    check();
  } catch (const Error& e) {
    throw BadArgument(e.what());
  }
}

// The library's Localizer with the map it reads and a lock: process() runs without the GIL, so two Python
// threads may call into one localizer at once; they take turns.
class PyLocalizer {
 public:
  PyLocalizer(const py::handle& map, const py::object& params, const py::handle& backend)
      : map_(map_from(map, "map")), options_(localizer_options_from_python(params, text_from(backend, "backend"))) {
    as_bad_argument([&] { check_options_for_map(*map_, options_); });
    py::gil_scoped_release release;
    localizer_ = std::make_unique<Localizer>(*map_, options_);
  }

  PyResult process(const py::handle& points, const py::handle& odom, const py::handle& stamp,
                   const py::object& scan_id) {
    const double time = number_from(stamp, "stamp");
    as_bad_argument([&] { check_time(time, "stamp"); });
    const std::vector<Eigen::Vector3f> p = points_from(points, "points");
    std::optional<Pose> odometry;
    if (!odom.is_none()) odometry = pose_from(odom, "odom");
    std::optional<std::uint64_t> id;
    if (!scan_id.is_none()) id = count_from(scan_id, "scan_id");
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    if (odometry) as_bad_argument([&] { check_odometry(*map_, *odometry, localizer_->last_odometry(), "odom"); });
    const auto t0 = std::chrono::steady_clock::now();
    const ScanRecord& record = localizer_->process(time, p, odometry, id);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return result_of(record, ms);
  }

  void init_pose(const py::handle& pose, const py::object& covariance) {
    const Pose world_T_sensor = pose_from(pose, "pose");
    as_bad_argument([&] { check_pose_in_map(*map_, world_T_sensor, "pose"); });
    std::optional<LocalInitSpread> spread;
    if (!covariance.is_none()) {
      // The covariance's order: x, y, z, then the rotation vector in the sensor frame (PoseEstimate); the spread
      // the filter samples from has one sigma for x and y and one for roll and pitch.
      const Matrix6d c = covariance_from(covariance, "covariance");
      LocalInitSpread s;
      s.sigma_xy = std::sqrt(0.5 * (c(0, 0) + c(1, 1)));
      s.sigma_z = std::sqrt(c(2, 2));
      s.sigma_roll_pitch = std::sqrt(0.5 * (c(3, 3) + c(4, 4)));
      s.sigma_yaw = std::sqrt(c(5, 5));
      as_bad_argument([&] { check_spread_for_map(*map_, s, "covariance's "); });
      spread = s;
    }
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    if (spread)
      localizer_->reset_to(world_T_sensor, *spread);
    else
      localizer_->reset_to(world_T_sensor);
  }

  void init_global() {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    localizer_->reset_global();
  }

  void add_imu(const py::handle& samples) {
    const py::array_t<double> a = real_array(samples, "imu samples", "an array (t, ax, ay, az) or (M, 4)");
    const bool one = a.ndim() == 1 && a.shape(0) == 4;
    if (!one && !(a.ndim() == 2 && a.shape(1) == 4)) {
      throw BadArgument("imu samples must have shape (4,) or (M, 4): t, ax, ay, az (m/s^2, sensor frame)");
    }
    const std::size_t m = one ? 1 : static_cast<std::size_t>(a.shape(0));
    std::vector<ImuSample> imu(m);
    for (std::size_t i = 0; i < m; ++i) {
      const double* v = a.data() + 4 * i;
      for (int c = 0; c < 4; ++c) {
        if (!std::isfinite(v[c])) throw BadArgument("imu sample " + std::to_string(i) + " is not finite");
      }
      imu[i].time = v[0];
      imu[i].acceleration = Eigen::Vector3d(v[1], v[2], v[3]);
    }
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const ImuSample& s : imu) localizer_->add_imu(s);
  }

  // Copies (the filter's buffers change with the next scan): positions (N, 3) float32, orientations (N, 4) float32
  // as w x y z, weights (N,) float64 normalized.
  py::tuple particles() {
    std::vector<float> pos, rot;
    std::vector<double> w;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      const ParticleFilter& f = localizer_->filter();
      const std::size_t n = f.initialized() ? f.particle_count() : 0;
      if (n > 0) w = f.particle_weights();
      const ParticleArrays p = f.particles();
      pos.resize(3 * n);
      rot.resize(4 * n);
      for (std::size_t i = 0; i < n; ++i) {
        pos[3 * i] = p.x[i], pos[3 * i + 1] = p.y[i], pos[3 * i + 2] = p.z[i];
        rot[4 * i] = p.qw[i], rot[4 * i + 1] = p.qx[i], rot[4 * i + 2] = p.qy[i], rot[4 * i + 3] = p.qz[i];
      }
    }
    const auto n = static_cast<py::ssize_t>(w.size());
    py::array_t<float> positions({n, py::ssize_t{3}}), orientations({n, py::ssize_t{4}});
    std::copy(pos.begin(), pos.end(), positions.mutable_data());
    std::copy(rot.begin(), rot.end(), orientations.mutable_data());
    return py::make_tuple(positions, orientations, py::array_t<double>(n, w.data()));
  }

  py::dict summary() {
    RunSummary s;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      s = localizer_->summary();
    }
    py::dict d;
    d["scans"] = s.scans;
    d["updates"] = s.updates;
    d["converged"] = s.converged;
    d["converged_since_time"] = s.converged_since_time ? py::cast(*s.converged_since_time) : py::none();
    d["converged_since_index"] = s.converged_since_index ? py::cast(*s.converged_since_index) : py::none();
    d["particles_min"] = s.particles_min;
    d["particles_max"] = s.particles_max;
    d["particles_final"] = s.particles_final;
    d["update_ms_mean"] = s.update_ms_mean;
    d["update_ms_median"] = s.update_ms_median;
    d["update_ms_max"] = s.update_ms_max;
    return d;
  }

  const Localizer& get() const { return *localizer_; }

 private:
  std::shared_ptr<TsdfMap> map_;  // outlives the localizer, which reads it
  LocalizerOptions options_;
  std::unique_ptr<Localizer> localizer_;
  std::mutex mutex_;
};

void register_results(py::module_& m) {
  py::class_<PyPlace>(m, "Place", "A place of the belief (one of its modes)")
      .def_property_readonly(
          "pose", [](const PyPlace& h) { return matrix_array(h.pose); }, "4x4 world_T_sensor")
      .def_property_readonly(
          "covariance", [](const PyPlace& h) { return matrix_array(h.covariance); },
          "6x6: x, y, z (m), then the rotation vector in the sensor frame (rad)")
      .def_readonly("weight", &PyPlace::weight, "share of the belief")
      .def_readonly("particles", &PyPlace::particles)
      .def_readonly("std_position", &PyPlace::std_position, "m")
      .def_readonly("std_rotation", &PyPlace::std_rotation, "rad")
      .def_readonly("inlier_ratio", &PyPlace::inlier_ratio)
      .def("__repr__", [](const PyPlace& h) {
        const Eigen::Vector3d t = h.pose.translation();
        return "<Place " + std::to_string(100.0 * h.weight) + " % at (" + std::to_string(t.x()) + ", " +
               std::to_string(t.y()) + ", " + std::to_string(t.z()) + ")>";
      });

  py::class_<PyResult>(m, "Result", "What one Localizer.process call did")
      .def_readonly("time", &PyResult::time)
      .def_readonly("index", &PyResult::index, "the scan's number in this run")
      .def_readonly("state", &PyResult::state,
                    "searching, ambiguous, converged, unmapped (a converged track carried through space the map "
                    "does not cover) or lost")
      .def_readonly("reason", &PyResult::reason, "why the state is what it is")
      .def_readonly("coverage", &PyResult::coverage,
                    "map coverage: share of the scan's points with map evidence at the estimate")
      .def_readonly("converged", &PyResult::converged)
      .def_readonly("updated", &PyResult::updated, "False: the motion gate held the scan; only the estimate moved")
      .def_readonly("resampled", &PyResult::resampled)
      .def_property_readonly(
          "estimate", [](const PyResult& r) { return matrix_array(r.estimate.pose); }, "4x4 world_T_sensor")
      .def_property_readonly(
          "covariance", [](const PyResult& r) { return matrix_array(r.estimate.covariance); },
          "6x6: x, y, z (m), then the rotation vector in the sensor frame (rad)")
      .def_property_readonly("place_weight", [](const PyResult& r) { return r.estimate.weight; })
      .def_property_readonly("inlier_ratio", [](const PyResult& r) { return r.estimate.inlier_ratio; })
      .def_readonly("places", &PyResult::places, "the belief's places (its heaviest modes), heaviest first")
      .def_readonly("particles", &PyResult::particles, "particles weighted in this update")
      .def_readonly("next_particles", &PyResult::next_particles)
      .def_readonly("injected", &PyResult::injected, "random particles from recovery")
      .def_readonly("ess", &PyResult::ess)
      .def_readonly("points", &PyResult::points, "input, in_range, thinned, used")
      .def_readonly("timings", &PyResult::timings,
                    "milliseconds: preprocess, motion, upload, weight, reduce, resample, update (the filter) and "
                    "process (the whole library call)")
      .def("__repr__", [](const PyResult& r) {
        const Eigen::Vector3d t = r.estimate.pose.translation();
        return "<Result scan " + std::to_string(r.index) + " " + r.state + " at (" + std::to_string(t.x()) + ", " +
               std::to_string(t.y()) + ", " + std::to_string(t.z()) + ")>";
      });
}

}  // namespace

void register_localizer(py::module_& m) {
  register_results(m);
  py::class_<PyLocalizer>(m, "Localizer", "Global 6-DoF localization of a LiDAR in a Map, one scan at a time")
      .def(py::init<const py::handle&, const py::object&, const py::handle&>(), py::arg("map"),
           py::arg("params") = py::none(), py::arg("backend") = py::str("auto"),
           "params: a dict of the parameters of tsdf-mcl localize --help by name (numbers, strings, lists, bools for "
           "flags), or the path of a YAML/JSON parameter file; backend: auto, vulkan or cpu (wins over params).")
      .def("process", &PyLocalizer::process, py::arg("points"), py::arg("odom"), py::arg("stamp"),
           py::arg("scan_id") = py::none(),
           "One scan: points float32 (N, 3|4) in the sensor frame, odom the 4x4 odom_T_sensor (None without "
           "odometry), stamp in seconds. Returns a Result.")
      .def("init_global", &PyLocalizer::init_global, "Search the whole map again from the next scan.")
      .def("init_pose", &PyLocalizer::init_pose, py::arg("pose"), py::arg("covariance") = py::none(),
           "Particles around the 4x4 world_T_sensor now; covariance (6x6) sets their spread, else the init_sigma_* "
           "parameters.")
      .def("add_imu", &PyLocalizer::add_imu, py::arg("samples"),
           "IMU samples, (4,) or (M, 4): t, specific force x y z in the sensor frame (m/s^2), in time order; "
           "gravity for the global search.")
      .def("particles", &PyLocalizer::particles, "(positions (N, 3), orientations (N, 4) w x y z, weights (N,))")
      .def("summary", &PyLocalizer::summary)
      .def_property_readonly("backend", [](const PyLocalizer& l) { return l.get().evaluator().backend(); })
      .def_property_readonly("device", [](const PyLocalizer& l) { return l.get().evaluator().device_name(); })
      .def_property_readonly("backend_note", [](const PyLocalizer& l) { return l.get().backend_note(); });
  register_parameters(m);
}

}  // namespace tsdf_mcl::python
