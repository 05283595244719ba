#include "arguments.hpp"

#include <cmath>

namespace tsdf_mcl::python {
namespace {

bool is_bool(const py::handle& obj) {
  return py::isinstance<py::bool_>(obj) || py::isinstance(obj, py::module_::import("numpy").attr("bool_"));
}

bool is_integer(const py::handle& obj) {
  return !is_bool(obj) && py::isinstance(obj, py::module_::import("numbers").attr("Integral"));
}

}  // namespace

std::string path_from(const py::handle& obj, const char* name) {
  const py::module_ os = py::module_::import("os");
  if (!py::isinstance<py::str>(obj) && !py::isinstance(obj, os.attr("PathLike"))) {
    throw BadType(std::string(name) + " must be a str or os.PathLike, not " + type_name(obj));
  }
  // os.fsdecode: a PathLike may give bytes; the file system's encoding turns them into the name the system sees.
  const std::string path = py::str(os.attr("fsdecode")(obj));
  if (path.find('\0') != std::string::npos) throw BadArgument(std::string(name) + " holds a NUL character");
  if (path.empty()) throw BadArgument(std::string(name) + " is empty");
  return path;
}

double number_from(const py::handle& obj, const char* name) {
  if (is_bool(obj) || !py::isinstance(obj, py::module_::import("numbers").attr("Real"))) {
    throw BadType(std::string(name) + " must be a real number, not " + type_name(obj));
  }
  double v = 0.0;
  try {
    v = py::float_(py::reinterpret_borrow<py::object>(obj));
  } catch (const py::error_already_set&) {  // an int beyond a double's range
    throw BadArgument(std::string(name) + " is out of range, got " + std::string(py::repr(obj)).substr(0, 40));
  }
  if (!std::isfinite(v)) throw BadArgument(std::string(name) + " must be finite, got " + std::string(py::repr(obj)));
  return v;
}

std::uint64_t count_from(const py::handle& obj, const char* name, std::uint64_t max) {
  if (!is_integer(obj)) throw BadType(std::string(name) + " must be an int, not " + type_name(obj));
  const py::int_ value(py::reinterpret_borrow<py::object>(obj));
  if (value < py::int_(0) || value > py::int_(max)) {
    throw BadArgument(std::string(name) + " must lie in 0.." + std::to_string(max) + ", got " +
                      std::string(py::str(py::object(value))));
  }
  return value.cast<std::uint64_t>();
}

bool flag_from(const py::handle& obj, const char* name) {
  if (!is_bool(obj)) throw BadType(std::string(name) + " must be True or False, not " + type_name(obj));
  return py::cast<bool>(py::bool_(py::reinterpret_borrow<py::object>(obj)));
}

std::string text_from(const py::handle& obj, const char* name) {
  if (!py::isinstance<py::str>(obj)) throw BadType(std::string(name) + " must be a str, not " + type_name(obj));
  return obj.cast<std::string>();
}

std::shared_ptr<TsdfMap> map_from(const py::handle& obj, const char* name) {
  if (!py::isinstance<TsdfMap>(obj)) {
    const std::string what =
        py::isinstance<py::type>(obj) ? "the class " + std::string(py::str(obj.attr("__name__"))) : type_name(obj);
    throw BadType(std::string(name) + " must be a tsdf_mcl.Map (Map.load, build_map_from_*), not " + what);
  }
  return obj.cast<std::shared_ptr<TsdfMap>>();
}

}  // namespace tsdf_mcl::python
