// No step allocates (issue 17): every integrator's step, with a held poke, makes no heap
// allocation once the simulation is set up. This executable counts every operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

#include "lamina/sim/simulation.h"
#include "sim/preconditioner.h"  // white box: the hierarchy's levels
#include "sim/solver.h"          // white box: the assembly switched on for a small model
#include "support/sphere_model.h"
#include "support/tet_phantom.h"

namespace {
std::atomic<int64_t> allocations{0};

void* counted(size_t size, size_t alignment) {
  allocations.fetch_add(1, std::memory_order_relaxed);
  size = size == 0 ? 1 : size;
  if (alignment <= alignof(std::max_align_t)) return std::malloc(size);
  return std::aligned_alloc(alignment, (size + alignment - 1) / alignment * alignment);
}
void* counted_or_throw(size_t size, size_t alignment) {
  if (void* p = counted(size, alignment)) return p;
  throw std::bad_alloc();
}
}  // namespace

// Every form of operator new and delete, so that each allocation and its release pair up in
// malloc and free (under AddressSanitizer too, which checks the pairing).
void* operator new(size_t n) {
  return counted_or_throw(n, 0);
}
void* operator new[](size_t n) {
  return counted_or_throw(n, 0);
}
void* operator new(size_t n, const std::nothrow_t&) noexcept {
  return counted(n, 0);
}
void* operator new[](size_t n, const std::nothrow_t&) noexcept {
  return counted(n, 0);
}
void* operator new(size_t n, std::align_val_t a) {
  return counted_or_throw(n, static_cast<size_t>(a));
}
void* operator new[](size_t n, std::align_val_t a) {
  return counted_or_throw(n, static_cast<size_t>(a));
}
void* operator new(size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted(n, static_cast<size_t>(a));
}
void* operator new[](size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted(n, static_cast<size_t>(a));
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}

namespace lamina {
namespace {

int64_t allocations_in_steps(sim::Simulation& s, int steps) {
  const int64_t before = allocations.load();
  for (int k = 0; k < steps; ++k) sim::step(s);
  return allocations.load() - before;
}

sim::Simulation poked(const Model& m, const sim::Material& mat, const sim::SolverOptions& o,
                      int32_t stride = 1) {
  sim::Simulation s = sim::make_simulation(m, mat, o);
  sim::fix_nodes(s, {0, 1, 2});
  s.f_ext.row(m.node_count() / 2) << 120.0, -60.0, 30.0;
  if (o.mode == sim::Mode::kLocal) {
    std::vector<int32_t> local;
    // A few nodes around the poke, consecutive (the model's blocks of lanes) or every stride-th
    // (scattered over many blocks: local mode's own blocks, LocalLanes).
    for (int32_t k = -20; k < 20; ++k) local.push_back(m.node_count() / 2 + stride * k);
    sim::set_local_nodes(s, local);
  }
  sim::step(s);  // the first step may size what it caches
  return s;
}

TEST(StepAllocation, NoStepAllocates) {
  const Model& links = test::sphere_links_model();
  const Model& tets = test::sphere_model();
  struct Case {
    const char* name;
    const Model& model;
    sim::Material material;
    sim::SolverOptions options;
    int32_t stride = 1;  ///< local mode's nodes: every stride-th about the poke
  };
  const Case cases[] = {
      {"explicit, global (the lanes)", links, {}, {}},
      {"explicit, local", links, {}, {.mode = sim::Mode::kLocal}},
      {"explicit, local, scattered", links, {}, {.mode = sim::Mode::kLocal}, 7},
      {"explicit, volume term", links, {.volume_stiffness_kpa = 5.0}, {}},
      {"implicit Euler", links, {}, {.integrator = sim::Integrator::kImplicitEuler}},
      {"implicit Euler, tetrahedra",
       tets,
       {.stiffness_n_per_m = 0.0, .node_mass_kg = 0.0, .young_modulus_kpa = 6.0},
       {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.001}},
      {"implicit Euler, tetrahedra, multigrid",
       test::tet_phantom(),
       test::kTetLiver,
       {.integrator = sim::Integrator::kImplicitEuler,
        .dt_s = 0.01,
        .preconditioner = sim::Preconditioner::kMultigrid}},
  };
  {  // the control: the counter does see the library's allocations
    sim::Simulation s = poked(links, {}, {});
    const int64_t before = allocations.load();
    const sim::SimState state = sim::capture_state(s);
    EXPECT_GT(allocations.load() - before, 0) << "operator new is not counted";
  }
  for (const Case& c : cases) {
    sim::Simulation s = poked(c.model, c.material, c.options, c.stride);
    if (c.stride > 1) EXPECT_TRUE(s.solver().lanes.local.on) << c.name;
    EXPECT_EQ(allocations_in_steps(s, 50), 0) << c.name;
    EXPECT_GT((s.x - c.model.X).cwiseAbs().maxCoeff(), 1e-3) << c.name << ": nothing moved";
    if (c.options.preconditioner == sim::Preconditioner::kMultigrid) {
      ASSERT_TRUE(sim::uses_multigrid(s)) << c.name;
      EXPECT_GE(s.solver().multigrid->mg.levels.size(), 2u) << c.name << ": no coarse level";
    }
  }
  {  // the tetrahedra's stiffness assembled each step (on by itself from 200,000 tetrahedra)
    const Case& c = cases[5];
    ASSERT_EQ(c.options.preconditioner, sim::Preconditioner::kAuto);
    sim::Simulation s = poked(c.model, c.material, c.options);
    sim::detail::setup_tet_assembly(s.solver());
    sim::step(s);
    EXPECT_EQ(allocations_in_steps(s, 50), 0) << "implicit Euler, tetrahedra assembled";
    EXPECT_TRUE(s.solver().tets.assembly.current) << "the last step did not assemble";
  }
}

}  // namespace
}  // namespace lamina
