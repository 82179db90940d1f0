// A page's resection plan (web_plan.h).
#include "web_plan.h"

#include <nlohmann/json.hpp>

#include "lamina/core/error.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/plan_on_model.h"

namespace lamina::net::web {

std::string plan_reply(const Model& m, uint64_t model_version, const Eigen::MatrixX3d& x,
                       const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                       PlanCache& cache) {
  nlohmann::json reply{{"type", "plan"}};
  const int32_t skin = model::display_skin_index(m);
  if (cache.model_version != model_version) {
    cache.made = model::model_territories(m);
    cache.skin_seed.clear();
    if (skin >= 0)
      for (const ModelVesselTree& t : m.trees)
        cache.skin_seed.push_back(model::nearest_seeds(t, m.embedded[skin].V));
    cache.model_version = model_version;
  }
  const geometry::ResectionSurface plane = geometry::plane_surface(point, normal);
  geometry::ResectionReport r;
  try {
    r = model::plan_on_model(m, x, plane, {}, {}, &cache.made);
  } catch (const Error& e) {  // a plane beside the organ: said to the page, which plans on
    reply["error"] = e.what();
    return reply.dump();
  }
  // The page's panel: the volumes, the FLR, the functional remnant (the report lamina resect
  // --json gives is io's; the page needs these).
  reply["remnant_ml"] = r.remnant_ml;
  reply["resected_ml"] = r.resected_ml;
  reply["flr_percent"] = r.flr_percent;
  reply["flr_sufficient"] = r.flr_sufficient;
  nlohmann::json tumours = nlohmann::json::array();
  for (const geometry::TumourMargin& t : r.tumours)
    tumours.push_back({{"name", t.name}, {"side", t.side}, {"margin_mm", t.margin_mm}});
  reply["tumours"] = tumours;
  if (r.functional) {
    const geometry::FunctionalRemnant& f = *r.functional;
    reply["functional"] = {{"percent", r.functional_flr_percent},
                           {"sufficient", r.functional_sufficient},
                           {"functional_ml", f.functional_ml},
                           {"devascularized_ml", f.devascularized_ml},
                           {"congested_ml", f.congested_ml}};
  } else {
    reply["functional_missing"] = r.functional_missing;
  }
  reply["skin_surface"] = skin;
  if (skin >= 0) {
    Eigen::MatrixX3d P;
    model::embedded_positions(m.embedded[skin], x, P);
    // Without trees the functional remnant is empty: the remnant's side plain, the rest not.
    const std::vector<uint8_t> state = model::surface_function(
        m, cache.skin_seed, r.functional.value_or(geometry::FunctionalRemnant{}), P, point, normal,
        r.remnant_in_front);
    reply["skin_state"] = state;
  }
  return reply.dump();
}

}  // namespace lamina::net::web
