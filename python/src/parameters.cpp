#include "parameters.hpp"

#include <map>

#include "numpy_io.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"

namespace tsdf_mcl::python {
namespace {

// A dict value as the text a command line or a parameter file would give: bools as flags' true/false, lists and
// tuples comma-separated (init, init_height_band), numbers in their shortest exact form (Python's str).
std::string text_of(const py::handle& value, const std::string& name) {
  if (value.is_none()) throw BadArgument("parameter '" + name + "' is None");
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value) || py::isinstance<py::array>(value)) {
    std::string joined;
    for (const py::handle v : value) joined += (joined.empty() ? "" : ",") + text_of(v, name);
    return joined;
  }
  const py::module_ numbers = py::module_::import("numbers");
  if (py::isinstance(value, numbers.attr("Number"))) return py::str(value);
  throw BadArgument("parameter '" + name + "' must be a number, a string, a bool or a list, not " +
                    std::string(py::str(py::type::handle_of(value).attr("__name__"))));
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
    const std::string path = py::str(os.attr("fspath")(params));
    values = read_parameter_file(path);
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
