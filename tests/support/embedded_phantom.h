#pragma once
// A small phantom with its anatomy embedded (about 700 nodes): a 5000-triangle display skin and
// the vessel tree and tumour at 1000 triangles each, built once per test program, for the tests
// of what carries the embedded surfaces out (run's frames, serve's messages).

#include <memory>
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

/// The same anatomy loaded as separate masks beside a whole-organ mask (lamina build
/// --embed-mask, issue 61): the same surfaces with the same roles, each of label 0 (a mask's
/// every non-zero voxel). Whatever reads a structure must find it in both.
inline const Model& embedded_phantom_from_masks() {
  static const Model m = [] {
    const LabelVolume labels = geometry::make_phantom({.spacing_mm = {3, 3, 3}, .anatomy = true});
    const auto mask_of = [&](int32_t label, const char* file) {
      auto v = std::make_shared<LabelVolume>(labels);
      for (int32_t& l : v->labels) l = l == label ? 1 : 0;
      v->source = file;
      return v;
    };
    model::BuildOptions o;
    o.skin_vertices = 400;
    o.display_triangles = 5000;
    o.structure_triangles = 1000;
    o.embed = {{.name = "vessels", .mask = mask_of(geometry::kPhantomVessel, "vessels.nii.gz")},
               {.name = "tumour", .mask = mask_of(geometry::kPhantomTumour, "tumour.nii.gz")}};
    return model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}), o).model;
  }();
  return m;
}

/// Saves it to `path` (.vtu) and returns the path; `from_masks`: the model of
/// embedded_phantom_from_masks().
inline std::string save_embedded_phantom(const std::string& path, bool from_masks = false) {
  io::save_model(from_masks ? embedded_phantom_from_masks() : embedded_phantom(), path);
  return path;
}

}  // namespace lamina::test
