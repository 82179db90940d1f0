#pragma once
// The world step's reusable buffers and internal passes (private to module world): each body's
// skin triangles in a hashed grid, the contacts found, each node's inverse mass. Sized once and
// reused, so that a step allocates nothing once the contacts' count has been reached.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "lamina/world/body_contact.h"
#include "lamina/world/world.h"

namespace lamina::world::detail {

/// A body's skin triangles at the current positions, bucketed by a hashed uniform grid: each
/// triangle in every cell its box (grown by the reach) overlaps. Rebuilt every step, in place.
struct SkinGrid {
  double cell_mm = 1.0;
  uint64_t mask = 0;           ///< buckets - 1 (a power of two)
  std::vector<int32_t> start;  ///< buckets + 1 offsets into items: bucket b from start[b] ...
  std::vector<int32_t> end;    ///< ... to end[b] (a bucket's slots may end unused)
  std::vector<int32_t> items;  ///< triangle rows of layer 0's F
  std::vector<int32_t> fill;   ///< scratch: each bucket's next slot while placing
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  ///< skin's box
  double mean_edge_mm = 0.0;  ///< of the skin at rest
};

/// A node of one body and a point of another body's skin (or its own) pulled to meet halfway
/// by implicit zero-length springs, one in each body's step: a contact (they meet where the
/// node sits at its rest overlap under the skin) or a tie (they meet at its length apart).
struct Coupling {
  int32_t body = -1, node = -1;  ///< the node's side (a slot, a node)
  int32_t other = -1;            ///< the skin's body (a slot)
  std::array<int32_t, 3> corners{};
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< where the node's spring pulls it, mm
  /// where each corner's spring (stiffness times its weight) pulls it, mm
  std::array<Eigen::Vector3d, 3> corner_targets{};
  double stiffness_n_per_m = 0.0;
  Tie* tie = nullptr;                                ///< a tie's coupling; null for a contact
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< a contact's: the skin's outward normal
  double allowance_mm = 0.0;                         ///< a contact's rest overlap
};

/// A pair of bodies' clearances (clearance.cpp): per skin node of the first, its distance from
/// the second's skin (capped) at reference positions of both, for the models they were made on.
struct Clearance {
  const Model* node_model = nullptr;
  const Model* skin_model = nullptr;
  double exclusion_mm = -1.0;
  std::vector<float> mm;
  Eigen::MatrixX3d node_ref, skin_ref;  ///< the two skins' rows at the reference
  /// the second skin's mean move since the reference, mm: the moves below are beyond it
  Eigen::RowVector3d shift = Eigen::RowVector3d::Zero();
  double other_move_mm = 0.0;  ///< the second skin's farthest move since, mm (beyond shift)
  SkinGrid grid;               ///< scratch: the second skin at the reference
  int64_t made = 0;            ///< references taken (for tests and profiles)
};

/// Clearances are searched this far, mm: a node farther has this. The references are taken
/// again once the two skins have moved half of it.
inline constexpr double kClearanceCapMm = 16.0;

/// A pair of bodies' near lists (near_lists.cpp): each skin node of the first that was within
/// radius_mm of the second's skin at the lists' reference, with the triangles of that skin it
/// was within radius_mm of (in-row order; self-contact's own neighbourhood left out). Good
/// while the two skins have moved no more than kNearSlackMm relative to the second's mean move.
struct NearLists {
  const Model* node_model = nullptr;
  const Model* skin_model = nullptr;
  double exclusion_mm = -1.0, radius_mm = -1.0;
  Eigen::MatrixX3d node_ref, skin_ref;  ///< the two skins' rows at the reference
  std::vector<int32_t> nodes;           ///< the listed nodes' rows of the first skin (k)
  std::vector<int32_t> start;           ///< nodes + 1 offsets into triangles
  std::vector<int32_t> triangles;       ///< rows of the second skin's F
  SkinGrid grid;                        ///< scratch: the second skin at the reference
  int64_t made = 0;                     ///< lists made (for tests and profiles)
};

/// The near lists' slack, mm: the search radius beyond the contact's reach, and how far the
/// skins may move (relative to each other) before the lists are made again.
inline constexpr double kNearSlackMm = 2.0;

struct WorldWork {
  std::vector<SkinGrid> grids;                 ///< per slot
  std::vector<uint8_t> grid_ready;             ///< per slot: its grid holds this step's skin
  std::vector<Clearance> clearance;            ///< per pair of slots (s * slots + t)
  std::vector<NearLists> near;                 ///< per pair of slots (s * slots + t)
  std::vector<std::vector<double>> node_area;  ///< per slot, per node: skin area, mm^2
  std::vector<Contact> contacts;
  std::vector<Coupling> couplings;
  std::vector<std::vector<int32_t>> spring_nodes;  ///< per slot: the couplings' nodes
  std::vector<std::vector<double>> spring_k;       ///< per slot: their stiffness
  /// per slot, per node: its contact spring pushed it out at the end of the last step (it
  /// stays in contact within ContactOptions::margin_mm outside the skin: no on-off chatter)
  std::vector<std::vector<uint8_t>> pushed;
  std::vector<uint8_t> had_springs;  ///< per slot: it had couplings last step
  std::vector<int32_t> row_of_slot;  ///< per slot, its row of WorldStepStats::bodies
  std::vector<int32_t> solve_order;  ///< live slots, the largest body first
};

/// The self-contact's exclusion, mm: ContactOptions::self_exclusion_mm if set; otherwise three
/// of the skin's mean edges, and never less than the contact's reach and the near lists' slack
/// (a skin meshed finer than its voxels has the staircase's smoothed bumps within a few edges
/// of every node: at 111k nodes a 3 mm exclusion read 6,952 of them as folds each step, and a
/// fold that meets itself comes from farther along the skin than the contact can reach).
inline double self_exclusion(const ContactOptions& o, double mean_edge_mm) {
  if (o.self_exclusion_mm > 0.0) return o.self_exclusion_mm;
  return std::max(3.0 * mean_edge_mm, o.reach_mm + kNearSlackMm);
}

/// The mean edge of `model`'s skin at rest, mm (one edge of each triangle): the grid's cell and
/// the self-contact's exclusion are multiples of it.
double skin_mean_edge(const Model& model);

/// Fills `grid` with the skin of `model` at positions x, grown by `reach_mm`.
void build_skin_grid(const Model& model, const Eigen::MatrixX3d& x, double reach_mm,
                     SkinGrid& grid);

/// The point of body b's skin with barycentric `weights` on the triangle `corners`, now.
inline Eigen::Vector3d point_on(const Body& b, const std::array<int32_t, 3>& corners,
                                const Eigen::Vector3d& weights) {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a) q += weights[a] * b.sim.x.row(corners[a]).transpose();
  return q;
}

/// The bucket of the cell holding point p.
uint64_t grid_bucket(const SkinGrid& grid, const Eigen::Vector3d& p);

/// Whether triangle f of the skin (its rows of F at positions x) is nearer p than `best`
/// (squared, mm^2); if so, `best` and the contact's triangle, weights, normal and signed depth
/// (> 0 inside) are its. The one test of both searches (a grid's bucket, a near list).
bool nearer_triangle(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x, int32_t f,
                     const Eigen::Vector3d& p, double& best, Contact& contact);

/// Whether triangle f of body `skin_model`'s skin is node `node`'s own neighbourhood in
/// self-contact: the node is a corner, or a corner lies within `exclusion_mm` of it at rest.
bool own_neighbourhood(const Model& model, int32_t f, int32_t node, double exclusion_mm);

/// The nearest point within `reach_mm` of node `node` (body `node_body`, position p) on the skin
/// of body `other` (its grid), skipping in self-contact the triangles whose corners all lie
/// within `exclusion_mm` of the node at rest. Fills `contact` (depth: the distance, signed:
/// > 0 inside) and returns false when no triangle is within reach.
bool nearest_on_skin(const Model& other_model, const Eigen::MatrixX3d& other_x,
                     const SkinGrid& grid, const Eigen::Vector3d& p, int32_t node, bool self,
                     const Model& node_model, double exclusion_mm, double reach_mm,
                     Contact& contact);

/// Every skin node inside a skin at the current positions (ContactOptions), into
/// work.contacts; with `rest_overlap` false, depths beyond each node's rest overlap. Nodes
/// whose clearance (clearance_of()) leaves them out of reach are not searched, unless
/// `every_node` (the tests' reference).
void find_contacts(World& world, bool measure_rest, bool every_node = false);

/// Before the solves: the couplings of this step (contacts found now, active ties), each one's
/// springs on its node and its corners (sim::set_contact_stiffness and their constant forces in
/// f_ext).
void begin_couplings(World& world);

/// After the solves: each spring's force at the new positions (the bodies' contact and
/// attachment forces in `out`), the ties' pulls (torn past their strength), the contacts'
/// depths.
void end_couplings(World& world, WorldStepStats& out);

/// Body t's skin's clearance from each skin node of body s (s == t: self-contact, the triangles
/// within `exclusion_mm` of the node at rest left out), with shift and other_move_mm of this
/// step; taken again when the skins have moved far (relative to t's mean move) since the last
/// reference.
const Clearance& clearance_of(World& world, int32_t s, int32_t t, double exclusion_mm);

/// The mean move of the skin's rows of x from `ref` (the skin's rows at a reference), mm.
Eigen::RowVector3d skin_mean_move(const Eigen::MatrixX3d& x, const ModelLayer& skin,
                                  const Eigen::MatrixX3d& ref);

/// Whether a skin row of x has moved from its row of `ref` more than `limit` mm beyond
/// `shift`; if not, `worst` is the farthest such move.
bool skin_moved_past(const Eigen::MatrixX3d& x, const ModelLayer& skin, const Eigen::MatrixX3d& ref,
                     const Eigen::RowVector3d& shift, double limit, double& worst);

/// Body t's near lists for the skin nodes of body s within `radius_mm` (s == t: self-contact,
/// its neighbourhood within `exclusion_mm` left out), made again when the skins have moved
/// kNearSlackMm since (the clearances, clearance_of(), skip the far nodes while making them).
const NearLists& near_lists_of(World& world, int32_t s, int32_t t, double exclusion_mm,
                               double radius_mm);

/// The skin area each node of layer 0 stands for (a third of its triangles'), mm^2.
std::vector<double> skin_node_area(const Model& model);

}  // namespace lamina::world::detail
