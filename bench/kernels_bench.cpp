// The simulation's kernels, one at a time, on the models `lamina bench` uses (built from the
// phantom: the paper's size, about 10k and about 100k nodes): the spring-force pass, one
// conjugate-gradient iteration of implicit Euler, the breadth-first rings, the tool's contact
// query and routing, and the skin volume. Each reports per-element times; `lamina bench` the
// whole steps.
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
#include "sim/force_terms.h"    // internal to sim: the tetrahedra's linearisation
#include "sim/solver.h"         // internal to sim: the assembled tetrahedra
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

// The tetrahedra's assembled product K p over every node, one thread (issue 48): `packed` 1
// is the steps' (p packed by node, a block row times p_j as one 4-wide vector,
// assembled_tet_product_packed, the packing included); 0 the scalar product over p's three
// columns it replaced, kept here as the reference measured in the same run.
void BM_AssembledProduct(benchmark::State& state) {
  const Model& m = model(state.range(0));
  sim::Simulation sim = sim::make_simulation(
      m, {.stiffness_n_per_m = 0.0, .node_mass_kg = 0.0, .young_modulus_kpa = 6.0},
      {.integrator = sim::Integrator::kImplicitEuler});
  sim::detail::Solver& s = sim.solver();
  if (!s.tets.on) {
    state.SkipWithError("the model has no tetrahedra");
    return;
  }
  const Eigen::MatrixX3d x = m.X * 1.02;
  const Eigen::MatrixX3d p = Eigen::MatrixX3d::Random(m.node_count(), 3);
  sim::detail::tet_pass(s, x, /*linearise=*/true, 1, &p);
  sim::detail::setup_tet_assembly(s);
  sim::detail::assemble_tets(s, 1);
  const sim::detail::TetAssembly& a = s.tets.assembly;
  Eigen::MatrixX3d y(m.node_count(), 3);
  const bool packed = state.range(1) != 0;
  std::vector<double>& pk = s.tets.assembly.packed;
  for (auto _ : state) {
    if (packed) {
      for (int32_t i = 0; i < m.node_count(); ++i)
        pk[4 * i] = p(i, 0), pk[4 * i + 1] = p(i, 1), pk[4 * i + 2] = p(i, 2);
      for (int32_t i = 0; i < m.node_count(); ++i) {
        double k[3] = {0.0, 0.0, 0.0};
        sim::detail::assembled_tet_product_packed(a, i, pk.data(), k);
        y(i, 0) = k[0], y(i, 1) = k[1], y(i, 2) = k[2];
      }
    } else {
      const double *px = p.col(0).data(), *py = p.col(1).data(), *pz = p.col(2).data();
      for (int32_t i = 0; i < m.node_count(); ++i) {
        double kx = 0.0, ky = 0.0, kz = 0.0;
        for (int32_t e = a.offsets[i]; e < a.offsets[i + 1]; ++e) {
          const int32_t j = a.column[e];
          const float* b = a.block.data() + 9 * static_cast<int64_t>(e);
          kx += b[0] * px[j] + b[1] * py[j] + b[2] * pz[j];
          ky += b[3] * px[j] + b[4] * py[j] + b[5] * pz[j];
          kz += b[6] * px[j] + b[7] * py[j] + b[8] * pz[j];
        }
        y(i, 0) = kx, y(i, 1) = ky, y(i, 2) = kz;
      }
    }
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
  }
  label(state, m);
  state.counters["blocks"] = static_cast<double>(a.column.size());
  state.counters["ns_per_block"] = per(state, static_cast<double>(a.column.size()));
}
BENCHMARK(BM_AssembledProduct)
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->ArgNames({"model", "packed"})
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

// A tool's touch-down through the paper's routing: the force-line crossings (every layer's
// triangles) and each copy spread over its rings, counted in edges (spacing 0) or by distance
// (the organ's paper-size spacing: a bounded Dijkstra search from each hit node).
void BM_RouteForce(benchmark::State& state) {
  const Model& m = model(state.range(0));
  const int32_t node = interact::most_anterior_skin_node(m);
  interact::RoutingOptions o;
  if (state.range(1) == 1) o.ring_spacing_mm = interact::paper_ring_spacing_mm(m);
  size_t nodes = 0;
  for (auto _ : state) {
    const interact::ForceRoute r = interact::route_force(m, m.X, node, {0, 400, 0}, o);
    nodes = r.nodes.size();
    benchmark::DoNotOptimize(r.forces.data());
  }
  label(state, m);
  state.counters["nodes_loaded"] = static_cast<double>(nodes);
}
BENCHMARK(BM_RouteForce)
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->ArgNames({"model", "by_distance"})
    ->Unit(benchmark::kMicrosecond);

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
