// A call that fits no signature (an argument missing, one too many, a misspelled keyword) gets pybind11's message:
// several lines listing the signatures and the arguments. Every function and method of the module is wrapped so that
// this message is one line naming the function, what it takes and what it got, as every other error of the module.
#include <pybind11/pybind11.h>

#include <sstream>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "numpy_io.hpp"

namespace tsdf_mcl::python {
namespace {

// "read_dataset(): takes (dir, start=0, stride=1, count=0); got 'x', 1, 2, 3, 4, 5" from pybind11's listing (a
// constructor's name is its class's).
std::string one_line_signature_error(const std::string& message) {
  std::istringstream in(message);
  std::string line, name, got = "no arguments";
  std::vector<std::string> signatures;
  std::getline(in, line);
  name = line.substr(0, line.find("(): "));
  while (std::getline(in, line)) {
    const std::size_t start = line.find_first_not_of(' ');
    if (start == std::string::npos) continue;
    line = line.substr(start);
    if (line.rfind("Invoked with:", 0) == 0) {
      const std::string rest = line.substr(13);
      if (rest.find_first_not_of(' ') != std::string::npos) got = rest.substr(rest.find_first_not_of(' '));
      continue;
    }
    // "1. (path: handle) -> tsdf_mcl.Map", or a constructor's "1. tsdf_mcl.Localizer(map: handle, ...)".
    const std::size_t dot = line.find(". "), open = line.find('(');
    if (dot == std::string::npos || open == std::string::npos || line.find_first_not_of("0123456789") != dot) continue;
    if (name == "__init__" && open > dot + 2) name = line.substr(dot + 2, open - dot - 2);
    std::string signature = line.substr(open, line.rfind(')') - open + 1);
    for (const std::string kind : {": handle", ": object", ": args", ": kwargs"}) {
      for (std::size_t at; (at = signature.find(kind)) != std::string::npos;) signature.erase(at, kind.size());
    }
    for (std::size_t at; (at = signature.find(" = ")) != std::string::npos;) signature.replace(at, 3, "=");
    signatures.push_back(signature);
  }
  std::string takes;
  for (const std::string& s : signatures) takes += (takes.empty() ? "" : " or ") + s;
  return name + "(): takes " + takes + "; got " + got;
}

// f(*args, **kwargs), its argument mismatch as one line; f's other errors unchanged.
py::object call_with_one_line_mismatch(const py::object& f, const py::args& args, const py::kwargs& kwargs) {
  try {
    return f(*args, **kwargs);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_TypeError)) throw;
    const std::string message = py::str(e.value());
    if (message.find("incompatible function arguments") == std::string::npos &&
        message.find("incompatible constructor arguments") == std::string::npos) {
      throw;
    }
    throw BadType(one_line_signature_error(message));
  }
}

py::cpp_function wrapper(const py::object& f, const py::object& owner, bool method) {
  const std::string name = py::str(f.attr("__name__"));
  const py::object doc_object = f.attr("__doc__");
  const std::string doc = doc_object.is_none() ? std::string() : std::string(py::str(doc_object));
  const auto call = [f](const py::args& args, const py::kwargs& kwargs) {
    return call_with_one_line_mismatch(f, args, kwargs);
  };
  if (method) return py::cpp_function(call, py::name(name.c_str()), py::is_method(owner), py::doc(doc.c_str()));
  return py::cpp_function(call, py::name(name.c_str()), py::scope(owner), py::doc(doc.c_str()));
}

bool is_builtin(const py::handle& obj) {
  return std::string(py::str(py::type::handle_of(obj).attr("__name__"))) == "builtin_function_or_method";
}

}  // namespace

void make_argument_errors_one_line(py::module_& m) {
  py::options options;
  options.disable_function_signatures();  // each wrapped function's docstring starts with its own already
  const py::object builtins = py::module_::import("builtins");
  for (const auto& [key, value] : py::dict(m.attr("__dict__"))) {
    if (is_builtin(value)) {
      m.attr(key) = wrapper(py::reinterpret_borrow<py::object>(value), m, false);
      continue;
    }
    if (!py::isinstance<py::type>(value)) continue;
    const py::object cls = py::reinterpret_borrow<py::object>(value);
    for (const auto& [name, member] : py::dict(cls.attr("__dict__"))) {
      const std::string kind = py::str(py::type::handle_of(member).attr("__name__"));
      if (kind == "instancemethod") {
        py::setattr(cls, name, wrapper(member.attr("__func__"), cls, true));
      } else if (kind == "staticmethod") {
        py::setattr(cls, name, builtins.attr("staticmethod")(wrapper(member.attr("__func__"), cls, false)));
      }
    }
  }
}

}  // namespace tsdf_mcl::python
