#pragma once
// Localizer parameters from Python: a dict by the names of tsdf-mcl localize --help, or a YAML/JSON file, through
// the library's one parameter schema (localizer_parameters.hpp).
#include <pybind11/pybind11.h>

#include <string>

#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::python {

// params: None, a dict or a path (str / os.PathLike); backend other than "auto" overrides params' backend.
// Raises ValueError with the library's message for an unknown name or a bad value.
LocalizerOptions localizer_options_from_python(const pybind11::object& params, const std::string& backend);

// parameter_specs(): the schema as a list of dicts (name, value_name, default, help, group).
void register_parameters(pybind11::module_& m);

}  // namespace tsdf_mcl::python
