#include "numpy_io.hpp"

#include <cmath>
#include <memory>

namespace tsdf_mcl::python {
namespace {

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string dtype_of(const py::array& a) { return py::str(a.dtype()); }

// What an argument is, for "must be X, not ...": an array's dtype, what a list holds, else its type.
std::string described(const py::handle& obj, const py::array& as_array) {
  if (py::isinstance<py::array>(obj)) return "an array of " + dtype_of(as_array);
  if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    return "a " + type_name(obj) + " of " +
           (as_array.dtype().kind() == 'O' ? std::string("other objects (None, str, rows of other lengths)")
                                           : dtype_of(as_array));
  }
  return type_name(obj);
}

}  // namespace

// Anything numpy reads as real numbers (lists, float32, integer arrays); complex numbers (whose imaginary part a cast
// drops), bools, strings and objects (None in a list) are refused.
py::array_t<double> real_array(const py::handle& obj, const char* name, const char* expected) {
  py::array any;
  try {
    any = py::module_::import("numpy").attr("asarray")(obj);
  } catch (const py::error_already_set&) {  // ragged lists, objects numpy cannot read
    throw BadArgument(std::string(name) + " must be " + expected + ", not " + type_name(obj));
  }
  const char kind = any.dtype().kind();
  if (kind == 'c') throw BadArgument(std::string(name) + " holds complex numbers; pass real numbers (.real)");
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw BadArgument(std::string(name) + " must be " + expected + " of real numbers, not " + described(obj, any));
  }
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(any);
  if (!a) {
    PyErr_Clear();
    throw BadArgument(std::string(name) + " must be " + expected + ", not " + type_name(obj));
  }
  const double* v = a.data();
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (!std::isfinite(v[i])) throw BadArgument(std::string(name) + " holds a non-finite value (NaN or Inf)");
  }
  return a;
}

namespace {

// A float64 array of the given shape (-1: any length on that axis), from real_array.
py::array_t<double> doubles_from(const py::handle& obj, const char* name, std::initializer_list<py::ssize_t> shape,
                                 const char* expected) {
  const py::array_t<double> a = real_array(obj, name, expected);
  bool ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
  py::ssize_t d = 0;
  for (const py::ssize_t s : shape) {
    ok = ok && (s < 0 || a.shape(d) == s);
    ++d;
  }
  if (!ok) throw BadArgument(std::string(name) + " must be " + expected + ", got shape " + shape_of(a));
  return a;
}

Pose rigid_from(const double* m, const std::string& name) {
  Eigen::Matrix4d t;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) t(r, c) = m[4 * r + c];
  if (std::abs(t(3, 0)) > 1e-9 || std::abs(t(3, 1)) > 1e-9 || std::abs(t(3, 2)) > 1e-9 ||
      std::abs(t(3, 3) - 1.0) > 1e-9) {
    throw BadArgument(name + " is not a rigid transform: its last row must be 0 0 0 1");
  }
  if (!is_rotation_matrix(t.topLeftCorner<3, 3>())) {
    throw BadArgument(name + " is not a rigid transform: its upper-left 3x3 is not a rotation (orthonormal, det +1)");
  }
  Pose p = Pose::Identity();
  p.linear() = t.topLeftCorner<3, 3>();
  p.translation() = t.topRightCorner<3, 1>();
  // A rotation orthonormal to rounding passes unchanged, so poses read from a dataset give the CLI's results bit
  // for bit; one from a text file with 6-9 digits is re-orthonormalized as the library does.
  const Eigen::Matrix3d r = p.linear();
  if ((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-12) return p;
  return orthonormalized(p);
}

}  // namespace

std::string type_name(const py::handle& obj) { return py::str(py::type::handle_of(obj).attr("__name__")); }

std::vector<Eigen::Vector3f> points_from(const py::handle& obj, const char* name, bool allow_empty) {
  const std::string n(name);
  if (!py::isinstance<py::array>(obj)) {
    throw BadArgument(n + " must be a numpy array of float32, shape (N, 3) or (N, 4), not " + type_name(obj));
  }
  const auto any = py::reinterpret_borrow<py::array>(obj);
  if (!py::isinstance<py::array_t<float>>(obj)) {
    throw BadArgument(n + " must be float32 (native byte order), got " + dtype_of(any) + "; use " + n +
                      ".astype(numpy.float32)");
  }
  if (any.ndim() != 2 || (any.shape(1) != 3 && any.shape(1) != 4)) {
    throw BadArgument(n + " must have shape (N, 3) or (N, 4), got " + shape_of(any));
  }
  const auto a = py::reinterpret_borrow<py::array_t<float>>(obj);
  const auto r = a.unchecked<2>();
  const py::ssize_t count = r.shape(0);
  if (count == 0 && !allow_empty) throw BadArgument(n + " holds no point");
  std::vector<Eigen::Vector3f> points(static_cast<std::size_t>(count));
  for (py::ssize_t i = 0; i < count; ++i) {
    const Eigen::Vector3f p(r(i, 0), r(i, 1), r(i, 2));
    if (!p.allFinite()) {
      throw BadArgument(n + " row " + std::to_string(i) + " is not finite (NaN or Inf); drop such rows first: " + n +
                        "[numpy.isfinite(" + n + ").all(axis=1)]");
    }
    points[static_cast<std::size_t>(i)] = p;
  }
  return points;
}

std::vector<Eigen::Vector3f> positions_from(const py::handle& obj, const char* name) {
  const py::array_t<double> a = doubles_from(obj, name, {-1, 3}, "an array of shape (N, 3)");
  std::vector<Eigen::Vector3f> out(static_cast<std::size_t>(a.shape(0)));
  const double* v = a.data();
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = Eigen::Vector3d(v[3 * i], v[3 * i + 1], v[3 * i + 2]).cast<float>();
  return out;
}

Pose pose_from(const py::handle& obj, const char* name) {
  return rigid_from(doubles_from(obj, name, {4, 4}, "a 4x4 rigid transform").data(), name);
}

std::vector<Pose> poses_from(const py::handle& obj, const char* name) {
  const py::array_t<double> a =
      doubles_from(obj, name, {-1, 4, 4}, "an array of 4x4 rigid transforms, shape (N, 4, 4)");
  std::vector<Pose> poses;
  poses.reserve(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    poses.push_back(rigid_from(a.data() + 16 * i, std::string(name) + "[" + std::to_string(i) + "]"));
  }
  return poses;
}

Matrix6d covariance_from(const py::handle& obj, const char* name) {
  const py::array_t<double> a = doubles_from(obj, name, {6, 6}, "a 6x6 covariance");
  Matrix6d c;
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) c(r, k) = a.data()[6 * r + k];
  const double scale = std::max(1.0, c.cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    throw BadArgument(std::string(name) + " is not symmetric");
  }
  if ((c.diagonal().array() < 0.0).any()) throw BadArgument(std::string(name) + " has a negative variance");
  return c;
}

std::vector<double> values_from(const py::handle& obj, const char* name) {
  const py::array_t<double> a = doubles_from(obj, name, {-1}, "a 1-D array of numbers");
  return {a.data(), a.data() + a.size()};
}

py::array_t<double> matrix_array(const Pose& pose) {
  py::array_t<double> a({4, 4});
  auto w = a.mutable_unchecked<2>();
  const Eigen::Matrix4d m = pose.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) w(r, c) = m(r, c);
  return a;
}

py::array_t<double> matrix_array(const Matrix6d& m) {
  py::array_t<double> a({6, 6});
  auto w = a.mutable_unchecked<2>();
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) w(r, c) = m(r, c);
  return a;
}

py::array_t<double> poses_array(const std::vector<Pose>& poses) {
  py::array_t<double> a({static_cast<py::ssize_t>(poses.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto w = a.mutable_unchecked<3>();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Matrix4d m = poses[i].matrix();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) w(static_cast<py::ssize_t>(i), r, c) = m(r, c);
  }
  return a;
}

py::array_t<float> points_array(std::vector<Eigen::Vector3f>&& points) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");
  const auto count = static_cast<py::ssize_t>(points.size());
  if (count == 0) return py::array_t<float>(std::vector<py::ssize_t>{0, 3});
  auto* owned = new std::vector<Eigen::Vector3f>(std::move(points));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<Eigen::Vector3f>*>(p); });
  return py::array_t<float>({count, py::ssize_t{3}}, {py::ssize_t{3 * sizeof(float)}, py::ssize_t{sizeof(float)}},
                            owned->front().data(), owner);
}

}  // namespace tsdf_mcl::python
