// Resection planning on a clinical-size label volume (512x512x130 at 0.6x0.6x1.6 mm, the phantom
// with its carved-out anatomy: liver, portal vein, two tumours, hepatic veins, vena cava), made
// in memory (file reading is `lamina resect`'s, timed in docs/resection.md). The reference in the
// same run: preparing the organ's mask alone, which every plan does first. Every benchmark
// reports the process's peak resident memory.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/geometry/prepare_mask.h"
#include "peak_rss.h"

namespace {

using namespace lamina;

using bench::peak_rss_mb;

const LabelVolume& clinical_labels() {
  static const LabelVolume v = geometry::make_phantom(
      {.spacing_mm = {0.6, 0.6, 1.6}, .size = {512, 512, 130}, .carved_out = true});
  return v;
}

// Three structures, as the target names: portal vein, tumours, hepatic veins.
geometry::ResectionOptions three_structures() {
  geometry::ResectionOptions o = geometry::planning_phantom_options();
  o.structures.pop_back();  // the vena cava, mostly outside the organ
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
