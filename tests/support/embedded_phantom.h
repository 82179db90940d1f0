#pragma once
// A small phantom with its anatomy embedded (about 700 nodes): a 5000-triangle display skin and
// the vessel tree and tumour at 1000 triangles each, built once per test program, for the tests
// of what carries the embedded surfaces out (run's frames, serve's messages).

#include <string>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/model_file.h"
#include "lamina/model/build_model.h"

namespace lamina::test {

inline const Model& embedded_phantom() {
  static const Model m = [] {
    model::BuildOptions o;
    o.skin_vertices = 400;
    o.display_triangles = 5000;
    o.structure_triangles = 1000;
    o.embed = {{.name = "vessels", .label = geometry::kPhantomVessel},
               {.name = "tumour", .label = geometry::kPhantomTumour}};
    return model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}, .anatomy = true}), o)
        .model;
  }();
  return m;
}

/// Saves it to `path` (.vtu) and returns the path.
inline std::string save_embedded_phantom(const std::string& path) {
  io::save_model(embedded_phantom(), path);
  return path;
}

}  // namespace lamina::test
