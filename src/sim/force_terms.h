#pragma once
// The model's internal forces, one term each behind one contract, visited in one fixed list
// (internal to module sim). Adding an energy is one file that defines a term's functions and one
// entry in the lists below; nothing that computes a whole-model force, energy or stiffness names
// a term.
//
// Every term is a struct of static functions (the list is a type, so a visit compiles to plain
// calls: no virtual dispatch, nothing decided per element):
//   on(s)                            whether this model and material carry the term
//   forces(s, x, f)                  its forces at any x over the whole model, added to f (mN)
//   energy_mj(s, x)                  its energy at x, mN mm (= 1e-6 J)
//   add_stiffness_rows(s, row)       each node's Gershgorin row sum of its stiffness at rest,
//                                    added to row (N/m): explicit_dt_limit()
//   add_rest_stiffness(s, row_of, K) its stiffness at rest as 3x3 blocks between rows
//                                    row_of[node] (-1: left out): the multigrid's levels and the
//                                    slowest vibration (rest_stiffness.cpp)
//
// The energies of the tetrahedra (TetEnergies: exactly one is on when TetTerm::on) also meet the
// step: each writes the shared per-corner rows of TetTerm (force, product, diag) that the node
// sweeps gather, so every integrator takes a new energy without a change.
//   setup(s)                         its per-block constants, after setup_tets()'s shared tables
//   pass(s, x, linearise, threads, product_of)
//                                    the active blocks' corner forces into tets.force; with
//                                    linearise also the linearisation and tets.diag, with
//                                    product_of the first product K p into tets.product
//   product_pass(s, p, threads)      the active blocks' shares of K p into tets.product
//   block_stiffness(s, k, out)       block k's 16 3x3 blocks of K as linearised, out[4 r + c]
//                                    [3 a + d][lane] for corners r, c (TetAssembly)
//   corner_forces(s, x, t)           one tetrahedron's corner forces at any x
//
// The springs' and the volume term's own step passes (spring_term.cpp, spring_lanes.h,
// volume_term.cpp) are not behind this list: their layouts (signed adjacency, SIMD lanes of
// springs, per-layer multipliers) are what makes them fast, and a new energy does not touch them.
#include <Eigen/Core>
#include <utility>
#include <vector>

#include "solver.h"

namespace lamina::sim::detail {

/// The springs of a model without tetrahedra (with them, the tetrahedra carry the edges).
struct EdgeSprings {
  static bool on(const Solver& s) { return !s.tets.on; }
  static void forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);
  static double energy_mj(const Solver& s, const Eigen::MatrixX3d& x);
  /// The energy at x of the springs with a movable end (`active`: s.active_springs) or of the
  /// others (the part refresh_frozen_positions() caches: local mode's springs that stay put).
  static double part_energy_mj(const Solver& s, const Eigen::MatrixX3d& x, bool active);
  static void add_stiffness_rows(const Solver& s, std::vector<double>& row);
  static void add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                 BlockRows& out);
};

/// The coupled springs of each tetrahedron with its volume (tet_term.cpp).
struct CoupledTets {
  static bool on(const Solver& s) { return s.tets.on && !s.tets.neo_hookean; }
  static void setup(Solver& s);
  static void pass(Solver& s, const Eigen::MatrixX3d& x, bool linearise, int threads,
                   const Eigen::MatrixX3d* product_of);
  static void product_pass(Solver& s, const Eigen::MatrixX3d& p, int threads);
  static void block_stiffness(const Solver& s, size_t k, double out[16][9][kTetLanes]);
  static Eigen::Matrix<double, 1, 12> corner_forces(const Solver& s, const Eigen::MatrixX3d& x,
                                                    int64_t t);
  static void forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);
  static double energy_mj(const Solver& s, const Eigen::MatrixX3d& x);
  static void add_stiffness_rows(const Solver& s, std::vector<double>& row);
  static void add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                 BlockRows& out);
};

/// Stable Neo-Hookean tetrahedra (neo_hookean_term.cpp; Material::tet_model kNeoHookean).
struct NeoHookeanTets {
  static bool on(const Solver& s) { return s.tets.on && s.tets.neo_hookean; }
  static void setup(Solver& s);
  static void pass(Solver& s, const Eigen::MatrixX3d& x, bool linearise, int threads,
                   const Eigen::MatrixX3d* product_of);
  static void product_pass(Solver& s, const Eigen::MatrixX3d& p, int threads);
  static void block_stiffness(const Solver& s, size_t k, double out[16][9][kTetLanes]);
  static Eigen::Matrix<double, 1, 12> corner_forces(const Solver& s, const Eigen::MatrixX3d& x,
                                                    int64_t t);
  static void forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);
  static double energy_mj(const Solver& s, const Eigen::MatrixX3d& x);
  static void add_stiffness_rows(const Solver& s, std::vector<double>& row);
  static void add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                 BlockRows& out);
  /// Tetrahedron t's 12 x 12 stiffness at rest (linear elasticity), N/m.
  static Eigen::Matrix<double, 12, 12> rest_element(const Solver& s, int64_t t);
};

/// The volume term between layers (volume_term.cpp; Material::volume_stiffness_kpa). Its rest
/// stiffness is left out: a rank-one term per layer, dense over the layer, that the slow bending
/// modes barely excite and that would fill the matrix.
struct LayerVolume {
  static bool on(const Solver& s) { return s.material.volume_stiffness_kpa > 0.0; }
  static void forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);
  static double energy_mj(const Solver& s, const Eigen::MatrixX3d& x);
  static void add_stiffness_rows(const Solver& s, std::vector<double>& row);
  static void add_rest_stiffness(const Solver&, const std::vector<int32_t>&, BlockRows&) {}
};

/// Anchors and the elastic support: a zero-length spring from each node to its rest position
/// (support_term.cpp).
struct NodeSupport {
  static bool on(const Solver&) { return true; }
  static void forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);
  static double energy_mj(const Solver& s, const Eigen::MatrixX3d& x);
  static void add_stiffness_rows(const Solver& s, std::vector<double>& row);
  static void add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                 BlockRows& out);
};

template <class... T>
struct TermList {};

/// Every internal force term, in the order their forces and energies are summed.
using Terms = TermList<EdgeSprings, CoupledTets, NeoHookeanTets, LayerVolume, NodeSupport>;
/// The energies a tetrahedron can store (Material::tet_model).
using TetEnergies = TermList<CoupledTets, NeoHookeanTets>;

/// Calls visit(T{}) for every term T of the list that is on, in the list's order.
template <class... T, class Visit>
void for_each_term(TermList<T...>, const Solver& s, Visit&& visit) {
  (
      [&] {
        if (T::on(s)) visit(T{});
      }(),
      ...);
}

/// Calls visit(E{}) for the energy E the tetrahedra store (nothing when they are off).
template <class Visit>
void with_tet_energy(const Solver& s, Visit&& visit) {
  for_each_term(TetEnergies{}, s, std::forward<Visit>(visit));
}

// The step's passes over the tetrahedra, whichever energy they store.
inline void tet_pass(Solver& s, const Eigen::MatrixX3d& x, bool linearise, int threads,
                     const Eigen::MatrixX3d* product_of = nullptr) {
  with_tet_energy(s, [&](auto e) { decltype(e)::pass(s, x, linearise, threads, product_of); });
}
inline void tet_product_pass(Solver& s, const Eigen::MatrixX3d& p, int threads) {
  with_tet_energy(s, [&](auto e) { decltype(e)::product_pass(s, p, threads); });
}
inline Eigen::Matrix<double, 1, 12> tet_corner_forces(const Solver& s, const Eigen::MatrixX3d& x,
                                                      int64_t t) {
  Eigen::Matrix<double, 1, 12> out = Eigen::Matrix<double, 1, 12>::Zero();
  with_tet_energy(s, [&](auto e) { out = decltype(e)::corner_forces(s, x, t); });
  return out;
}

/// A tetrahedron's 12 x 12 stiffness added to the 3x3 blocks between its corners' rows
/// (row_of[node]; -1: left out), for any energy (tet_term.cpp).
void add_element_blocks(const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4],
                        const std::vector<int32_t>& row_of, BlockRows& out);

/// Where the assembly's table (TetAssembly, set up) puts each of its entries in `out`: per
/// entry, out's block between the two nodes' rows (row_of), or -1 when either has none.
/// \note Throws lamina::Error (kInternal) for a pair of rows out's pattern lacks.
std::vector<int32_t> table_blocks(const TetAssembly& a, const std::vector<int32_t>& row_of,
                                  const BlockRows& out);
/// add_element_blocks() for tetrahedron t through the table (no search), only into the rows in
/// [lo, hi): threads owning ranges of rows add the same tetrahedra in the same order as one.
void add_element_rows(const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4],
                      const int32_t* entry, const std::vector<int32_t>& row_of,
                      const std::vector<int32_t>& block_of, int64_t lo, int64_t hi, BlockRows& out);

}  // namespace lamina::sim::detail
