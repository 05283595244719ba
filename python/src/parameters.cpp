#include "parameters.hpp"

#include <map>
#include <optional>

#include "arguments.hpp"
#include "numpy_io.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"

namespace tsdf_mcl::python {
namespace {

// One value as the text a command line or a parameter file would give: bools as flags' true/false, real numbers
// in their shortest exact form (Python's str); nullopt for anything else.
std::optional<std::string> scalar_text(const py::handle& value) {
  if (py::isinstance<py::bool_>(value) || py::isinstance(value, py::module_::import("numpy").attr("bool_"))) {
    return py::cast<bool>(py::bool_(py::reinterpret_borrow<py::object>(value))) ? "true" : "false";
  }
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance(value, py::module_::import("numbers").attr("Real"))) return std::string(py::str(value));
  return std::nullopt;
}

// A dict value as text: a scalar, or a flat list, tuple or 1-D array of two or more scalars comma-separated (init,
// init_height_band). Nested or self-containing lists are refused, not followed: one level is all a parameter takes.
std::string text_of(const py::handle& value, const std::string& name) {
  if (value.is_none()) throw BadArgument("parameter '" + name + "' is None");
  if (const auto text = scalar_text(value)) return *text;
  const bool array = py::isinstance<py::array>(value);
  if (array && py::reinterpret_borrow<py::array>(value).ndim() != 1) {
    throw BadArgument("parameter '" + name + "' must be a 1-D list of values, got an array of shape " +
                      std::string(py::str(value.attr("shape"))));
  }
  if (!array && !py::isinstance<py::list>(value) && !py::isinstance<py::tuple>(value)) {
    throw BadArgument("parameter '" + name + "' must be a number, a string, a bool or a list, not " + type_name(value));
  }
  std::string joined;
  for (const py::handle v : value) {
    const auto text = scalar_text(v);
    if (!text) {
      throw BadArgument("parameter '" + name + "' must list numbers, strings or bools, not " + type_name(v) +
                        " (lists are not nested)");
    }
    joined += (joined.empty() ? "" : ",") + *text;
  }
  if (py::len(value) < 2) {
    throw BadArgument("parameter '" + name + "' is a list of " + std::to_string(py::len(value)) +
                      " items; give a single value without brackets");
  }
  return joined;
}

}  // namespace

LocalizerOptions localizer_options_from_python(const py::object& params, const std::string& backend) {
  std::map<std::string, std::string> values;
  if (py::isinstance<py::dict>(params)) {
    for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(params)) {
      if (!py::isinstance<py::str>(key)) throw BadArgument("parameter names must be strings");
      const std::string name = key.cast<std::string>();
      values[name] = text_of(value, name);
    }
  } else if (!params.is_none()) {
    const py::module_ os = py::module_::import("os");
    if (!py::isinstance<py::str>(params) && !py::isinstance(params, os.attr("PathLike"))) {
      throw BadArgument("params must be a dict or the path of a YAML/JSON parameter file");
    }
    values = read_parameter_file(path_from(params, "params"));
  }
  if (backend != "auto") values["backend"] = backend;
  try {
    return localizer_options_from(values);
  } catch (const Error& e) {
    throw BadArgument(e.what());
  }
}

void register_parameters(py::module_& m) {
  m.def(
      "parameter_specs",
      [] {
        py::list out;
        for (const ParameterSpec& s : localizer_parameter_specs()) {
          out.append(py::dict(py::arg("name") = s.name, py::arg("value_name") = s.value_name,
                              py::arg("default") = s.default_value, py::arg("help") = s.help,
                              py::arg("group") = s.group));
        }
        return out;
      },
      "The localization parameters (the names of tsdf-mcl localize --help) with their defaults and help.");
}

}  // namespace tsdf_mcl::python
