#pragma once
// Shared by the binding files of the Python module: each registers one part of the API.
#include <pybind11/pybind11.h>

namespace lamina::python {

void bind_model(pybind11::module_& m);       // masks, models (bind_model.cpp)
void bind_simulation(pybind11::module_& m);  // simulations, tools, scenes (bind_simulation.cpp)

}  // namespace lamina::python
