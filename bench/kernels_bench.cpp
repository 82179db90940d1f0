// The simulation's kernels, one at a time, on the models `lamina bench` uses (built from the
// phantom: the paper's size, about 10k and about 100k nodes): the spring-force pass, one
// conjugate-gradient iteration of implicit Euler, the breadth-first rings, the tool's contact
// query and the skin volume. Each reports per-element times; `lamina bench` the whole steps.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "lamina/geometry/make_phantom.h"
#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/model/compute_rings.h"
#include "lamina/sim/simulation.h"
#include "sim/spring_kernel.h"  // internal to sim: the benchmark runs it in float

namespace {

using namespace lamina;

// 0: the paper's size (1284 skin vertices, 2 layers); 1: about 10k nodes; 2: about 100k nodes.
// Tetrahedra between the layers (the default), or the paper's links (`lamina bench`'s networks).
const Model& model(int64_t size, bool links = false) {
  static std::map<std::pair<int64_t, bool>, Model> cache;
  auto it = cache.find({size, links});
  if (it == cache.end()) {
    const int32_t skin[] = {1284, 6500, 33500}, layers[] = {2, 2, 5};
    model::BuildOptions options{.layers = layers[size], .skin_vertices = skin[size]};
    if (links) options.structure = model::Structure::kLinks;
    it = cache
             .emplace(std::pair{size, links},
                      model::build_model(geometry::make_phantom(), options).model)
             .first;
  }
  return it->second;
}

void label(benchmark::State& state, const Model& m) {
  state.counters["nodes"] = m.node_count();
  state.counters["springs"] = static_cast<double>(m.springs.size());
}

// Per-element time as a counter: ns per `elements` per iteration.
benchmark::Counter per(benchmark::State& state, double elements) {
  return benchmark::Counter(static_cast<double>(state.iterations()) * elements,
                            benchmark::Counter::kIsRate | benchmark::Counter::kInvert,
                            benchmark::Counter::kIs1000);
}

// Spring forces at a deformed shape: each spring once, then each node sums its springs.
void BM_SpringForces(benchmark::State& state) {
  const Model& m = model(state.range(0));
  sim::Simulation s = sim::make_simulation(m);
  Eigen::MatrixX3d x = m.X;
  x.col(1) *= 1.02;  // stretched 2% along y: every spring has a force
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  for (auto _ : state) {
    sim::spring_forces(s, x, f);
    benchmark::ClobberMemory();
  }
  label(state, m);
  state.counters["ns_per_spring"] = per(state, static_cast<double>(m.springs.size()));
}
BENCHMARK(BM_SpringForces)->DenseRange(0, 2)->ArgName("model")->Unit(benchmark::kMicrosecond);

// The precision study: the step's own spring kernel (sim::spring_kernel) over the model's
// springs, with positions, rest lengths, stiffnesses and output in float or in double. Only the
// arithmetic width differs; the library steps in double (docs/benchmarks.md says why).
template <class Real>
void BM_SpringKernelPrecision(benchmark::State& state) {
  const Model& m = model(state.range(0));
  const Springs& sp = m.springs;
  const auto n = static_cast<int64_t>(sp.size());
  std::vector<Real> rest(sp.rest_length_mm.begin(), sp.rest_length_mm.end()), k(sp.size(), Real(3)),
      f(3 * sp.size());
  std::vector<Real> p(3 * static_cast<size_t>(m.node_count()));
  for (int32_t i = 0; i < m.node_count(); ++i)
    for (int c = 0; c < 3; ++c) p[c * m.node_count() + i] = static_cast<Real>(1.02 * m.X(i, c));
  const Real* px = p.data();
  for (auto _ : state) {
    sim::spring_kernel<Real>(0, n, nullptr, sp.i.data(), sp.j.data(), rest.data(), k.data(), px,
                             px + m.node_count(), px + 2 * m.node_count(), f.data(), f.data() + n,
                             f.data() + 2 * n);
    benchmark::ClobberMemory();
  }
  label(state, m);
  state.counters["ns_per_spring"] = per(state, static_cast<double>(n));
  // How finely float can place a node of this model: the spacing of floats at its largest
  // coordinate (patient coordinates, not centred), against the 1e-4 mm convergence threshold.
  const auto far = static_cast<float>(m.X.cwiseAbs().maxCoeff());
  state.counters["float_spacing_mm"] = std::nextafter(far, 2.0f * far) - far;
}
BENCHMARK(BM_SpringKernelPrecision<float>)
    ->DenseRange(0, 2)
    ->ArgName("model")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringKernelPrecision<double>)
    ->DenseRange(0, 2)
    ->ArgName("model")
    ->Unit(benchmark::kMicrosecond);

// One conjugate-gradient iteration's product (M + h gamma + h^2 K) p, K linearised by a step:
// of the tetrahedra and their edges' springs, or of the paper's springs (links: 1).
void BM_CgIteration(benchmark::State& state) {
  const Model& m = model(state.range(0), state.range(1) != 0);
  sim::Simulation s = sim::make_simulation(m, {}, {.integrator = sim::Integrator::kImplicitEuler});
  s.x.col(1) *= 1.02;
  sim::step(s);
  const Eigen::MatrixX3d p = Eigen::MatrixX3d::Random(m.node_count(), 3);
  Eigen::MatrixX3d y = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  for (auto _ : state) {
    sim::implicit_system_product(s, s.options().dt_s, p, y);
    benchmark::ClobberMemory();
  }
  label(state, m);
  state.counters["ns_per_spring"] = per(state, static_cast<double>(m.springs.size()));
}
BENCHMARK(BM_CgIteration)
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->ArgNames({"model", "links"})
    ->Unit(benchmark::kMicrosecond);

// One whole step under a held poke, for comparison with the kernels (`lamina bench` reports the
// same on the links networks).
void BM_WholeStep(benchmark::State& state) {
  const Model& m = model(state.range(0), state.range(2) != 0);
  const auto integrator =
      state.range(1) ? sim::Integrator::kImplicitEuler : sim::Integrator::kSemiImplicitEuler;
  sim::Simulation s = sim::make_simulation(m, {}, {.integrator = integrator});
  s.f_ext.row(0) << 0.0, 400.0, 0.0;
  for (int k = 0; k < 10; ++k) sim::step(s);
  int32_t cg = 0;
  for (auto _ : state) cg = sim::step(s).cg_iterations;
  label(state, m);
  state.counters["cg_iterations"] = cg;
  state.counters["ns_per_spring"] = per(state, static_cast<double>(m.springs.size()));
}
BENCHMARK(BM_WholeStep)
    ->ArgsProduct({{0, 1, 2}, {0, 1}, {0, 1}})
    ->ArgNames({"model", "implicit", "links"})
    ->Unit(benchmark::kMicrosecond);

// The paper's neighbourhood rings by breadth-first search, up to locality N (done at build).
void BM_Rings(benchmark::State& state) {
  const Model& m = model(state.range(0));
  const auto locality = static_cast<int32_t>(state.range(1));
  for (auto _ : state) benchmark::DoNotOptimize(model::compute_rings(m, locality));
  label(state, m);
  state.counters["ns_per_node"] = per(state, m.node_count());
}
BENCHMARK(BM_Rings)
    ->ArgsProduct({{0, 1, 2}, {4}})
    ->ArgNames({"model", "locality"})
    ->Unit(benchmark::kMillisecond);

// The tool's contact: the nearest skin node to a point at the current shape (a k-d tree over
// the skin, built on the deformed positions, then one query), as when a tool touches down.
void BM_ContactQuery(benchmark::State& state) {
  const Model& m = model(state.range(0));
  const Eigen::Vector3d point = m.X.row(0).transpose() + Eigen::Vector3d(0.5, -0.5, 0.5);
  for (auto _ : state) benchmark::DoNotOptimize(interact::nearest_skin_node(m, m.X, point, 5.0));
  label(state, m);
  state.counters["skin_vertices"] = m.layers[0].node_count;
}
BENCHMARK(BM_ContactQuery)->DenseRange(0, 2)->ArgName("model")->Unit(benchmark::kMicrosecond);

// The skin's enclosed volume (measured every step).
void BM_SkinVolume(benchmark::State& state) {
  const Model& m = model(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(sim::layer_volume(m, m.X, 0));
  label(state, m);
  state.counters["ns_per_face"] = per(state, static_cast<double>(m.layers[0].F.rows()));
}
BENCHMARK(BM_SkinVolume)->DenseRange(0, 2)->ArgName("model")->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
