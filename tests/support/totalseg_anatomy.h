#pragma once
// TotalSegmentator's example liver with its structures (tests/data, 3 mm labels: 1 the liver,
// 2 the portal and splenic vein, 3 the vena cava, 4 the gallbladder, each beside the liver rather
// than in its mask), built with small display and structure surfaces: the tests that cut a real
// liver with its anatomy.

#include "lamina/io/label_volume_io.h"
#include "lamina/model/build_model.h"
#include "test_paths.h"

namespace lamina::test {

inline model::BuildOptions totalseg_anatomy_options() {
  model::BuildOptions o;
  o.labels = {1};
  o.display_triangles = 6000;
  o.structure_triangles = 1000;
  o.embed = {{.name = "portal_vein", .label = 2},
             {.name = "vena_cava", .label = 3},
             {.name = "gallbladder", .label = 4}};
  return o;
}

inline Model totalseg_anatomy() {
  return model::build_model(
             io::read_label_volume(real_data("liver_totalseg_example_3mm_labels.nii.gz")),
             totalseg_anatomy_options())
      .model;
}

}  // namespace lamina::test
