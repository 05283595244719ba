#pragma once
// The parts of the tsdf_mcl Python module, each registered by its own file.
#include <pybind11/pybind11.h>

namespace tsdf_mcl::python {

void register_map(pybind11::module_& m);        // Map, build_map_from_*
void register_dataset(pybind11::module_& m);    // Dataset, read_dataset, read_bag, evaluate
void register_localizer(pybind11::module_& m);  // Localizer, Result, Place, parameter_specs
// Wraps every function and method registered so far: a call that fits no signature is one line (signature_errors.cpp).
void make_argument_errors_one_line(pybind11::module_& m);

}  // namespace tsdf_mcl::python
