// Resection planning on a clinical-size label volume (512x512x130 at 0.6x0.6x1.6 mm, the phantom
// with its carved-out anatomy: liver, portal vein, two tumours, hepatic veins, vena cava), made
// in memory (file reading is `lamina resect`'s, timed in docs/resection.md). The reference in the
// same run: preparing the organ's mask alone, which every plan does first. Every benchmark
// reports the process's peak resident memory.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <numbers>

#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/model/build_model.h"
#include "lamina/model/plan_on_model.h"
#include "peak_rss.h"

namespace {

using namespace lamina;

using bench::peak_rss_mb;

const LabelVolume& clinical_labels() {
  static const LabelVolume v = geometry::make_phantom(
      {.spacing_mm = {0.6, 0.6, 1.6}, .size = {512, 512, 130}, .carved_out = true});
  return v;
}

// Three structures, as the target names: portal vein, tumours, hepatic veins (named so:
// their trees and territories are made, issue 63).
geometry::ResectionOptions three_structures() {
  geometry::ResectionOptions o = geometry::planning_phantom_options();
  o.structures.pop_back();  // the vena cava, mostly outside the organ
  return o;
}

// The same, the vessels named as no tree: the plan without the functional remnant.
geometry::ResectionOptions three_structures_without_trees() {
  geometry::ResectionOptions o = three_structures();
  for (geometry::ResectionStructure& s : o.structures)
    if (s.role != SurfaceRole::kTumour) s.name = "vessel " + std::to_string(s.label);
  return o;
}

void report(benchmark::State& state, const geometry::ResectionPlan& plan) {
  state.counters["voxels"] = static_cast<double>(clinical_labels().frame.voxel_count());
  state.counters["organ_ml"] = plan.report.whole_ml;
  state.counters["crossings"] = static_cast<double>(plan.report.crossings.size());
  state.counters["peak_rss_mb"] = peak_rss_mb();
}

void BM_PrepareOrganMask(benchmark::State& state) {
  const LabelVolume& v = clinical_labels();
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::prepare_mask(v, {.label = geometry::kPhantomLiver}));
  state.counters["peak_rss_mb"] = peak_rss_mb();
}
BENCHMARK(BM_PrepareOrganMask)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

void BM_PlanResectionPlane(benchmark::State& state) {
  const LabelVolume& v = clinical_labels();
  const geometry::SideOf side(geometry::plane_surface({30, 0, 0}, {1, 0.2, 0.1}));
  geometry::ResectionPlan plan;
  for (auto _ : state) plan = geometry::plan_resection(v, side, three_structures());
  report(state, plan);
}
BENCHMARK(BM_PlanResectionPlane)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

void BM_PlanResectionPlaneWithoutTrees(benchmark::State& state) {
  const LabelVolume& v = clinical_labels();
  const geometry::SideOf side(geometry::plane_surface({30, 0, 0}, {1, 0.2, 0.1}));
  geometry::ResectionPlan plan;
  for (auto _ : state) plan = geometry::plan_resection(v, side, three_structures_without_trees());
  report(state, plan);
}
BENCHMARK(BM_PlanResectionPlaneWithoutTrees)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

// The functional remnant again for a plane that moves, the trees and territories made once (as
// a viewer's plan panel would hold them): each voxel's side by its centre, then what the trees
// still reach. Each iteration moves the plane 1 mm.
void BM_FunctionalRemnantPerPlane(benchmark::State& state) {
  static const geometry::ResectionPlan plan = geometry::plan_resection(
      clinical_labels(), geometry::SideOf(geometry::plane_surface({30, 0, 0}, {1, 0.2, 0.1})),
      three_structures());
  const Mask& organ = plan.organ;
  const GridFrame& g = organ.frame;
  std::vector<uint8_t> kept(organ.inside.size(), 0), function;
  double x = 0.0, lost_ml = 0.0;
  for (auto _ : state) {
    x = x >= 40.0 ? -40.0 : x + 1.0;
    const Eigen::Vector3d n = Eigen::Vector3d(1, 0.2, 0.1).normalized();
    // The signed distance at voxel (i, j, k) is d0 + i a + j b + k c: one add a voxel.
    const auto o = g.to_physical(0, 0, 0);
    const double d0 = (Eigen::Vector3d(o[0], o[1], o[2]) - Eigen::Vector3d(x, 0, 0)).dot(n);
    double step[3];
    for (int a = 0; a < 3; ++a)
      step[a] = g.spacing_mm[a] *
                Eigen::Vector3d(g.direction[a], g.direction[3 + a], g.direction[6 + a]).dot(n);
    int64_t remnant = 0;
    for (int64_t k = 0; k < g.size[2]; ++k)
      for (int64_t j = 0; j < g.size[1]; ++j) {
        double d = d0 + static_cast<double>(j) * step[1] + static_cast<double>(k) * step[2];
        const int64_t row = g.index(0, j, k);
        for (int64_t i = 0; i < g.size[0]; ++i, d += step[0]) {
          const auto v = static_cast<size_t>(row + i);
          const bool keep = organ.inside[v] != 0 && d < 0.0;
          kept[v] = keep;
          remnant += keep;
        }
      }
    const geometry::FunctionalRemnant fr = geometry::functional_remnant(
        plan.trees, organ, kept, static_cast<double>(remnant) * g.voxel_volume_mm3() / 1000.0,
        function);
    lost_ml = fr.lost_ml;
  }
  state.counters["organ_voxels"] =
      static_cast<double>(plan.report.remnant_voxels + plan.report.resected_voxels);
  state.counters["seeds"] = static_cast<double>(plan.trees[0].territories.seeds.size() +
                                                plan.trees[1].territories.seeds.size());
  state.counters["lost_ml_last"] = lost_ml;
  state.counters["peak_rss_mb"] = peak_rss_mb();
}
BENCHMARK(BM_FunctionalRemnantPerPlane)->Unit(benchmark::kMillisecond)->Repetitions(3);

// A plan on the model (the viewer's, each time the plane moves) of the carved-out phantom at
// 1.5 mm built with its portal vein, tumours and hepatic veins, at a skin size; trees 0: the
// same model without its trees (the reference: the geometric plan alone). The territories are
// made once, as the viewer keeps them.
const Model& anatomy_model(int32_t skin_vertices) {
  static std::map<int32_t, Model> cache;
  auto it = cache.find(skin_vertices);
  if (it == cache.end()) {
    model::BuildOptions o;
    o.skin_vertices = skin_vertices;
    o.label = 1;
    for (const auto& s : three_structures().structures)
      o.embed.push_back({.name = s.name, .label = s.label});
    it = cache
             .emplace(skin_vertices,
                      model::build_model(geometry::make_phantom({.carved_out = true}), o).model)
             .first;
  }
  return it->second;
}

void BM_PlanOnModel(benchmark::State& state) {
  Model m = anatomy_model(static_cast<int32_t>(state.range(0)));
  if (state.range(1) == 0) m.trees.clear();
  const model::ModelTerritories made = model::model_territories(m);
  const geometry::ResectionOptions o;
  double x = 0.0, lost_ml = 0.0;
  for (auto _ : state) {
    x = x >= 40.0 ? -40.0 : x + 1.0;
    const geometry::ResectionReport r = model::plan_on_model(
        m, m.X, geometry::plane_surface({x, 0, 0}, Eigen::Vector3d(1, 0.2, 0.1).normalized()), o,
        {}, &made);
    lost_ml = r.functional ? r.functional->lost_ml : 0.0;
  }
  state.counters["nodes"] = m.node_count();
  state.counters["tets"] = static_cast<double>(m.tets.size());
  state.counters["samples"] = static_cast<double>(made.samples());
  state.counters["lost_ml_last"] = lost_ml;
  state.counters["peak_rss_mb"] = peak_rss_mb();
}
BENCHMARK(BM_PlanOnModel)
    ->ArgsProduct({{1284, 5000, 10000, 20000}, {0, 1}})
    ->ArgNames({"skin_vertices", "trees"})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(3);

// A curved surface of 2 x 100 x 100 triangles (a sheet bent along y across the organ): the
// AABB tree's queries, one per 4x4x4 block far from it and one per voxel near it.
void BM_PlanResectionCurvedSurface(benchmark::State& state) {
  const LabelVolume& v = clinical_labels();
  const int n = 100;
  Eigen::MatrixX3d V((n + 1) * (n + 1), 3);
  Eigen::MatrixX3i F(2 * n * n, 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double y = -150.0 + 300.0 * i / n, z = -150.0 + 300.0 * j / n;
      V.row(j * (n + 1) + i) << 20.0 + 25.0 * std::cos(std::numbers::pi * y / 150.0), y, z;
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i;
      F.row(2 * (j * n + i)) << a, a + 1, a + n + 2;
      F.row(2 * (j * n + i) + 1) << a, a + n + 2, a + n + 1;
    }
  const geometry::SideOf side(geometry::mesh_surface(V, F, "bent sheet"));
  geometry::ResectionPlan plan;
  for (auto _ : state) plan = geometry::plan_resection(v, side, three_structures());
  report(state, plan);
  state.counters["triangles"] = static_cast<double>(F.rows());
}
BENCHMARK(BM_PlanResectionCurvedSurface)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

}  // namespace

BENCHMARK_MAIN();
