#pragma once
// A page's "plan" message (docs/web.md "Messages from the page"): the resection plan on the
// organ's current shape along the page's plane, answered to that page: the volumes, the future
// liver remnant, the functional remnant, and what the display skin's vertices show
// (model::surface_function). The trees' territories are made once per model and kept.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/model/model_territories.h"

namespace lamina::net::web {

struct PlanCache {
  uint64_t model_version = ~uint64_t{0};  // the model the territories below were made for
  model::ModelTerritories made;
  std::vector<std::vector<int32_t>> skin_seed;  // per tree, per display-skin vertex
};

/// The reply (JSON text, "type": "plan"): remnant_ml, resected_ml, flr_percent, flr_sufficient,
/// tumours (name, side, margin_mm), functional (percent, sufficient, functional_ml,
/// devascularized_ml, congested_ml) or functional_missing, "skin_surface" (the display skin's index
/// among the drawn surfaces, -1 without one) and "skin_state" (per vertex, a
/// model::SurfaceFunction); or "error" when the plane cannot plan (it misses the organ).
std::string plan_reply(const Model& model, uint64_t model_version, const Eigen::MatrixX3d& x,
                       const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                       PlanCache& cache);

}  // namespace lamina::net::web
