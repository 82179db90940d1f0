#pragma once
// What a Python World holds, shared by its binding files (bind_world.cpp: stepping, views, cuts
// and serving; bind_world_edit.cpp: tools, materials and undo).
#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <vector>

#include "lamina/io/world_scene.h"
#include "lamina/world/cut_history.h"
#include "lamina/world/world.h"

namespace lamina::python {

struct PyWorld {
  io::WorldScene scene;
  std::unique_ptr<io::ReadyWorld> ready;
  world::WorldStepStats last;
  world::CutHistory cuts;  // the cuts since the last reset: an undo takes the newest back
  // What a cut, an undo or a reset replaced, kept: numpy views of x and rest taken before it
  // point into these buffers (they show the state before, never freed memory).
  struct Retired {
    std::shared_ptr<const Model> model;
    std::unique_ptr<sim::Simulation> sim;
  };
  std::vector<Retired> retired;
};

// Keeps body b's simulation (its buffers, which views may point into) and model, leaving the
// body a copy of them to change.
PyWorld::Retired& retire(PyWorld& w, world::Body& b);

// The body named `name`, or a one-line error listing the bodies there are.
world::Body& body_named(PyWorld& w, const std::string& name);
const world::Body& body_named(const PyWorld& w, const std::string& name);

void bind_world_edit(pybind11::class_<PyWorld>& world);  // bind_world_edit.cpp

}  // namespace lamina::python
