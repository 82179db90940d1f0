// The Python module `lamina._lamina` (imported as `lamina`, python/lamina/__init__.py): the
// library's plain structs and functions with keyword arguments, numpy views of the state, and
// lamina::Error raised as lamina.Error with the same one-line message (docs/python.md).
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "lamina/core/error.h"

namespace py = pybind11;

PYBIND11_MODULE(_lamina, m) {
  m.doc() = "Lamina: real-time multi-layer mass-spring soft tissue (units: mm, kg, s, mN)";
  m.attr("__version__") = LAMINA_VERSION;

  // lamina.Error carries the library's message and its kind as the CLI's exit code.
  static py::exception<lamina::Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const lamina::Error& e) {
      PyObject* type = error.ptr();
      py::object exc = py::reinterpret_borrow<py::object>(type)(e.what());
      exc.attr("exit_code") = e.exit_code();
      PyErr_SetObject(type, exc.ptr());
    }
  });

  lamina::python::bind_model(m);
  lamina::python::bind_simulation(m);
  lamina::python::bind_resect(m);
  lamina::python::bind_world(m);
}
