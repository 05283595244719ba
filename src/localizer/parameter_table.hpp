#pragma once
// The localizer's parameter table (parameter_table.cpp), private to the localizer layer.
#include <vector>

#include "tsdf_mcl/localizer/localizer_parameters.hpp"

namespace tsdf_mcl {

// Every parameter of localizer_parameter_specs(), built once from the library's defaults.
std::vector<ParameterSpec> localizer_parameter_table();

}  // namespace tsdf_mcl
