// The tsdf_mcl Python module: maps, localization and evaluation from numpy (docs/python.md).
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

PYBIND11_MODULE(tsdf_mcl, m) {
  namespace py = pybind11;
  using namespace tsdf_mcl::python;
  m.doc() = "6-DoF Monte Carlo localization of a LiDAR in a TSDF map (docs/python.md)";
  // The library's one-line errors (files, parameters it checks, scans it cannot use) keep their message, made one
  // line whatever user text (a parameter name, a path) they echo.
  static py::exception<tsdf_mcl::Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const BadType& e) {
      PyErr_SetString(PyExc_TypeError, tsdf_mcl::one_line(e.what()).c_str());
    } catch (const BadArgument& e) {
      PyErr_SetString(PyExc_ValueError, tsdf_mcl::one_line(e.what()).c_str());
    } catch (const tsdf_mcl::Error& e) {
      error(tsdf_mcl::one_line(e.what()).c_str());
    }
  });
  register_map(m);
  register_dataset(m);
  register_localizer(m);
  make_argument_errors_one_line(m);
#ifdef TSDF_MCL_VERSION
  m.attr("__version__") = TSDF_MCL_VERSION;
#endif
}
