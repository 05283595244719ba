#pragma once
// numpy <-> library conversions for the Python module, with the checks every entry point shares: a bad array
// (wrong type, dtype, shape, a NaN, a 4x4 that is not a rigid transform) raises ValueError naming the argument,
// before any library code runs.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"

namespace tsdf_mcl::python {

namespace py = pybind11;

// Raised as ValueError (the library's tsdf_mcl::Error stays tsdf_mcl.Error).
struct BadArgument : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};
// An argument of the wrong kind (None for a path, a str for a number): raised as TypeError.
struct BadType : BadArgument {
  using BadArgument::BadArgument;
};

// The name of obj's type, for messages.
std::string type_name(const py::handle& obj);

// A numpy array of float32, shape (N, 3) or (N, 4) (x y z [intensity]), any strides (a slice or a transposed
// view is read in place, no intermediate copy); every coordinate finite. Copied into the vector the library takes.
std::vector<Eigen::Vector3f> points_from(const py::handle& obj, const char* name, bool allow_empty = false);
// Positions only: float32 or float64, shape (N, 3).
std::vector<Eigen::Vector3f> positions_from(const py::handle& obj, const char* name);

// A rigid transform: a 4x4 array of floats, finite, last row 0 0 0 1, an orthonormal rotation with det +1
// (within kRotationTolerance; re-orthonormalized).
Pose pose_from(const py::handle& obj, const char* name);
// A 6x6 covariance: finite, symmetric, non-negative diagonal.
Matrix6d covariance_from(const py::handle& obj, const char* name);
// A float64 array of any shape from real numbers (an array, a list; not complex, bool, str, None), every value finite.
py::array_t<double> real_array(const py::handle& obj, const char* name, const char* expected);
// A 1-D array (or sequence) of finite float64 values.
std::vector<double> values_from(const py::handle& obj, const char* name);
// (N, 4, 4) array of rigid transforms.
std::vector<Pose> poses_from(const py::handle& obj, const char* name);

py::array_t<double> matrix_array(const Pose& pose);
py::array_t<double> matrix_array(const Matrix6d& m);
py::array_t<double> poses_array(const std::vector<Pose>& poses);
// The points as an (N, 3) float32 array that owns the vector's storage (no copy: Vector3f is three packed floats).
py::array_t<float> points_array(std::vector<Eigen::Vector3f>&& points);

}  // namespace tsdf_mcl::python
