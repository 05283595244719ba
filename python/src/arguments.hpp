#pragma once
// Python arguments that are not arrays (numpy_io.hpp has those): every entry point takes its arguments as Python
// objects and converts them here, so that a wrong argument is one line naming it (TypeError for the wrong kind of
// object, ValueError for a bad value) instead of pybind11's listing of overloads ("incompatible function
// arguments") or "Unable to cast Python instance to C++ type".
#include <pybind11/pybind11.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <string>

#include "numpy_io.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::python {

// A file or folder name: str or os.PathLike (pathlib.Path); a NUL character is refused (the system would read the
// name only up to it).
std::string path_from(const py::handle& obj, const char* name);
// A real number (int, float, numpy scalars; not bool, complex or str), finite.
double number_from(const py::handle& obj, const char* name);
// An integer (int or a numpy integer; not bool or float) in [0, max].
std::uint64_t count_from(const py::handle& obj, const char* name,
                         std::uint64_t max = std::numeric_limits<std::uint64_t>::max());
// A bool (or numpy.bool_); None, 0 or "yes" are not.
bool flag_from(const py::handle& obj, const char* name);
// A str.
std::string text_from(const py::handle& obj, const char* name);
// A tsdf_mcl.Map instance (not None, not the class itself).
std::shared_ptr<TsdfMap> map_from(const py::handle& obj, const char* name);

}  // namespace tsdf_mcl::python
