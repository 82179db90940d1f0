#pragma once
// Shared by the binding files of the Python module: each registers one part of the API.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/core/surface_role.h"
#include "lamina/interact/tools.h"
#include "lamina/net/serve.h"

namespace lamina::python {

// A structure's role as Python names it ("vessel", "tumour", "structure"), or a one-line error
// naming `what`.
inline SurfaceRole structure_role_of(const std::string& word, const std::string& what) {
  const auto r = role_from_name(word);
  if (!r || !is_anatomy(*r))
    throw invalid_input(what, "role '" + word + "' is not vessel, tumour or structure");
  return *r;
}

void bind_model(pybind11::module_& m);       // masks, models (bind_model.cpp)
void bind_simulation(pybind11::module_& m);  // simulations, tools, scenes (bind_simulation.cpp)
void bind_resect(pybind11::module_& m);      // resection planning (bind_resect.cpp)
void bind_world(pybind11::module_& m);       // worlds of several organs (bind_world.cpp)

// A tool pushing with force_mn (at point_mm or skin node `vertex`: exactly one), or a grasper
// pulling by pull_mm over pull_s, from start_s (default now_s) to end_s, checked; `what` names
// the call in errors (tool_args.cpp: Simulation's and World's add_tool and add_grasp).
interact::Tool tool_from(const std::string& what, std::optional<Eigen::Vector3d> point_mm,
                         std::optional<int32_t> vertex, const Eigen::Vector3d& force_mn,
                         std::optional<double> start_s, double end_s, double radius_mm,
                         double now_s);
interact::Tool grasp_from(const std::string& what, std::optional<Eigen::Vector3d> point_mm,
                          std::optional<int32_t> vertex, const Eigen::Vector3d& pull_mm,
                          double pull_s, std::optional<double> start_s, double end_s,
                          double radius_mm, double now_s);

// Serving (bind_serve.cpp): `lamina serve`'s options from Python's keywords (an unknown one, or
// a value it cannot take, is refused by name), checked.
net::ServeOptions serve_options(const pybind11::kwargs& kwargs);
// Runs `serve` with the GIL released, asking Python for signals between polls: Ctrl-C ends the
// serve (its summary logged) and is raised as KeyboardInterrupt. Returns serve's exit code.
int serve_until_interrupted(const std::function<int(const net::KeepGoing&)>& serve);

// A read-only numpy view of `data` (shape, strides in bytes) kept alive by `owner`: numpy's
// base is `owner`, so the memory lives as long as any view of it.
template <class T>
pybind11::array view(const T* data, std::vector<pybind11::ssize_t> shape,
                     std::vector<pybind11::ssize_t> strides, pybind11::handle owner) {
  namespace py = pybind11;
  py::array a(py::dtype::of<T>(), std::move(shape), std::move(strides), data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// An Eigen column-major matrix (rows x 3 or 4) as a read-only (rows, cols) view.
template <class M>
pybind11::array matrix_view(const M& x, pybind11::handle owner) {
  using T = typename M::Scalar;
  const auto s = static_cast<pybind11::ssize_t>(sizeof(T));
  return view(x.data(), {x.rows(), x.cols()}, {s, s * x.rows()}, owner);
}

}  // namespace lamina::python
