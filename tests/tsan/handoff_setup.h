#pragma once
// What every ThreadSanitizer program starts from (scripts/tsan.sh): its arguments
// (MODEL.vtu [SECONDS]), the model with its rings, and the soft material it is stepped with.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "lamina/io/model_file.h"
#include "lamina/model/compute_rings.h"
#include "lamina/sim/simulation.h"

namespace lamina::tsan {

struct HandoffSetup {
  std::shared_ptr<Model> model;
  double seconds = 5.0;
  sim::Material material;
};

// Nothing (the usage said on stderr) for too few arguments.
inline std::optional<HandoffSetup> handoff_setup(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODEL.vtu [SECONDS]\n", argv[0]);
    return std::nullopt;
  }
  HandoffSetup s;
  s.seconds = argc > 2 ? std::stod(argv[2]) : 5.0;
  s.model = std::make_shared<Model>(io::load_model(argv[1]));
  s.model->rings = model::compute_rings(*s.model, 4);
  s.material.stiffness_n_per_m = 20.0;
  s.material.damping_kg_per_s = 8.0;
  s.material.anchor_stiffness_n_per_m = 1.0;
  return s;
}

}  // namespace lamina::tsan
