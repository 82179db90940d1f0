// Simulation benchmarks: steps per second of each integrator on the paper-size model (1284 skin
// vertices, 2 layers) and on one about 10x larger, and the time from a poke to convergence against
// locality 1..6 at thresholds 1e-3 and 1e-4 mm (the paper's figure 5). The paper's parameters:
// K = 3, gamma = 3, unit masses, dt = 0.01, P = 4.
#include <benchmark/benchmark.h>

#include <map>

#include "lamina/geometry/make_phantom.h"
#include "lamina/interact/pick.h"
#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/sim/simulation.h"

namespace {

using namespace lamina;

const Model& phantom_model(int32_t skin_vertices) {
  static std::map<int32_t, Model> cache;
  auto it = cache.find(skin_vertices);
  if (it == cache.end())
    it = cache
             .emplace(skin_vertices,
                      model::build_model(geometry::make_phantom(),
                                         {.skin_vertices = skin_vertices, .locality = 6})
                          .model)
             .first;
  return it->second;
}

void BM_Step(benchmark::State& state) {
  const Model& m = phantom_model(static_cast<int32_t>(state.range(0)));
  const auto integrator =
      state.range(1) ? sim::Integrator::kImplicitEuler : sim::Integrator::kSemiImplicitEuler;
  sim::Simulation s = sim::make_simulation(m, {}, {.integrator = integrator});
  interact::ToolDriver d;
  d.tools.push_back({.vertex = interact::most_anterior_skin_node(m), .force_mn = Eigen::Vector3d(0, 50, 0)});
  interact::apply_tools(s, d);
  for (auto _ : state) benchmark::DoNotOptimize(sim::step(s));
  state.counters["nodes"] = m.node_count();
  state.counters["springs"] = static_cast<double>(m.springs.size());
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["ns_per_spring"] = benchmark::Counter(
      static_cast<double>(state.iterations() * m.springs.size()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert, benchmark::Counter::kIs1000);
  state.SetLabel(integrator == sim::Integrator::kImplicitEuler ? "implicit" : "semi-implicit");
}
BENCHMARK(BM_Step)
    ->ArgsProduct({{1284, 12840}, {0, 1}})
    ->ArgNames({"skin_vertices", "implicit"})
    ->Unit(benchmark::kMicrosecond);

// Poke (local mode, the paper's; 0.4 N as in examples/) and step until converged (the threshold
// held for 10 consecutive steps, 0.1 s): wall time and steps.
void BM_PokeToConvergence(benchmark::State& state) {
  const Model& m = phantom_model(1284);
  const int32_t locality = static_cast<int32_t>(state.range(0));
  const double threshold = state.range(1) == 3 ? 1e-3 : 1e-4;
  int64_t steps = 0;
  for (auto _ : state) {
    sim::Simulation s =
        sim::make_simulation(m, {}, {.threshold_mm = threshold, .mode = sim::Mode::kLocal});
    interact::ToolDriver d;
    d.routing.locality = locality;
    d.tools.push_back({.vertex = interact::most_anterior_skin_node(m), .force_mn = Eigen::Vector3d(0, 400, 0)});
    interact::apply_tools(s, d);
    steps = sim::run_to_convergence(s).converged ? s.steps : -1;
  }
  state.counters["steps"] = static_cast<double>(steps);
  state.counters["locality"] = locality;
}
BENCHMARK(BM_PokeToConvergence)
    ->ArgsProduct({{1, 2, 3, 4, 5, 6}, {3, 4}})
    ->ArgNames({"locality", "threshold_exp"})
    ->Unit(benchmark::kMillisecond);

}  // namespace

// Picking the skin under the mouse: a brute-force ray cast over the skin's triangles at the
// current positions (once per mouse press in the viewer).
void BM_PickSkin(benchmark::State& state) {
  const Model& m = phantom_model(static_cast<int32_t>(state.range(0)));
  const Eigen::Vector3d centre = m.X.colwise().mean().transpose();
  const Eigen::Vector3d origin = centre - Eigen::Vector3d(0, 400, 0);
  for (auto _ : state) {
    const interact::SkinHit hit = interact::pick_skin(m, m.X, origin, Eigen::Vector3d(0, 1, 0));
    benchmark::DoNotOptimize(hit.node);
  }
  state.counters["skin_faces"] = static_cast<double>(m.layers[0].F.rows());
}
BENCHMARK(BM_PickSkin)->Arg(1284)->Arg(12840)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
