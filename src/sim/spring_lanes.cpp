// The lanes' tables (spring_lanes.h): built once per model, their stiffness refilled when the
// material changes, their active blocks when the movable nodes do.
#include <algorithm>
#include <cmath>

#include "solver.h"
#include "spring_lanes_kernel.h"

namespace lamina::sim::detail {

void setup_spring_lanes(Solver& s) {
  const Model& m = *s.model;
  const Springs& sp = m.springs;
  const SpringTerm& st = s.springs;  // its per-node CSR (setup_springs)
  SpringLanes& t = s.lanes;
  const int32_t n = m.node_count(), blocks = block_count(n);
  t.nodes = n;
  for (int d = 0; d < 3; ++d) t.centre[d] = 0.5 * (m.X.col(d).minCoeff() + m.X.col(d).maxCoeff());
  t.slot_offsets.assign(static_cast<size_t>(blocks) + 1, 0);
  for (int32_t b = 0; b < blocks; ++b) {
    int32_t slots = 0;
    for (int32_t i = b * kLanes; i < std::min(n, (b + 1) * kLanes); ++i)
      slots = std::max(slots, st.adj_offsets[i + 1] - st.adj_offsets[i]);
    t.slot_offsets[b + 1] = t.slot_offsets[b] + slots;
  }
  const auto entries = static_cast<size_t>(t.slot_offsets[blocks]) * kLanes;
  t.other4.assign(entries, 0);
  t.inverse_rest.assign(entries, 0.0f);
  t.k_rest.assign(entries, 0.0f);
  t.rest_mm.assign(entries, 0.0);
  t.spring.assign(entries, -1);
  t.p.assign(4 * static_cast<size_t>(n), 0.0f);
  for (int32_t i = 0; i < n; ++i) pack_position(t, i, m.X(i, 0), m.X(i, 1), m.X(i, 2));
  alignas(64) float dx[kLanes], dy[kLanes], dz[kLanes], inverse[kLanes];
  for (int32_t b = 0; b < blocks; ++b)
    for (int32_t slot = t.slot_offsets[b]; slot < t.slot_offsets[b + 1]; ++slot) {
      const int32_t k = slot - t.slot_offsets[b];
      const size_t e0 = static_cast<size_t>(slot) * kLanes;
      for (int32_t q = 0; q < kLanes; ++q) {
        const int32_t i = std::min(b * kLanes + q, n - 1);  // a lane past the end reads node n-1
        const bool real = b * kLanes + q < n && k < st.adj_offsets[i + 1] - st.adj_offsets[i];
        const int32_t j = real ? st.adj_other[st.adj_offsets[i] + k] : i;
        t.other4[e0 + q] = 4 * j;
        t.spring[e0 + q] = real ? st.adj_spring[st.adj_offsets[i] + k] : -1;
        for (int d = 0; d < 3; ++d)
          (d == 0 ? dx : d == 1 ? dy : dz)[q] = t.p[4 * j + d] - t.p[4 * i + d];
      }
      // 1 / the edge's length at rest in the pass's own arithmetic: where the model's rest length
      // is that length, the pass sees exactly zero force at rest.
      inverse_length(FloatLanes::load_aligned(dx), FloatLanes::load_aligned(dy),
                     FloatLanes::load_aligned(dz))
          .store_aligned(inverse);
      for (int32_t q = 0; q < kLanes; ++q) {
        const int32_t e = t.spring[e0 + q];
        if (e < 0) continue;
        const double rest = sp.rest_length_mm[e];
        const int32_t i = std::min(b * kLanes + q, n - 1), j = t.other4[e0 + q] / 4;
        const double at_rest = (m.X.row(j) - m.X.row(i)).norm();
        t.rest_mm[e0 + q] = rest;
        // Rest lengths within float's resolution of the edge's length at rest (a model saved
        // and read back, a shrunk layer's) count as that length.
        t.inverse_rest[e0 + q] = std::abs(rest - at_rest) <= 1e-6 * rest
                                     ? inverse[q]
                                     : static_cast<float>(1.0 / std::max(rest, 1e-12));
      }
    }
}

void fill_spring_lanes(Solver& s) {
  SpringLanes& t = s.lanes;
  const std::vector<double>& k = s.springs.stiffness_n_per_m;
  for (size_t e = 0; e < t.spring.size(); ++e)
    t.k_rest[e] = t.spring[e] < 0 ? 0.0f : static_cast<float>(k[t.spring[e]] * t.rest_mm[e]);
  if (!t.stiffness.empty())
    for (size_t e = 0; e < t.spring.size(); ++e)
      t.stiffness[e] = t.spring[e] < 0 ? 0.0 : k[t.spring[e]];
  LocalLanes& l = t.local;
  for (size_t e = 0; e < l.entry.size(); ++e)
    l.k_rest[e] = l.entry[e] < 0 ? 0.0f : t.k_rest[static_cast<size_t>(l.entry[e])];
}

namespace {

// Local mode's own blocks (LocalLanes): when the movable nodes would use less than half the
// lanes of the model's blocks they lie in, and are few enough for one thread (fewer entries
// than lanes_threads() gives a second thread; larger regions take the per-spring passes, which
// split over threads).
void refresh_local_lanes(Solver& s) {
  SpringLanes& t = s.lanes;
  LocalLanes& l = t.local;
  const SpringTerm& st = s.springs;
  const auto count = static_cast<int32_t>(s.active_nodes.size());
  l.on = false;
  l.entry.clear();  // fill_spring_lanes() copies nothing while off
  if (s.tets.on || count == 0 ||
      2 * static_cast<size_t>(count) >= static_cast<size_t>(kLanes) * t.active_blocks.size())
    return;
  const int32_t blocks = block_count(count);
  const auto node = [&](int32_t lane) { return s.active_nodes[std::min(lane, count - 1)]; };
  const auto degree = [&](int32_t i) { return st.adj_offsets[i + 1] - st.adj_offsets[i]; };
  l.slot_offsets.assign(static_cast<size_t>(blocks) + 1, 0);
  for (int32_t b = 0; b < blocks; ++b) {
    int32_t slots = 0;
    for (int32_t q = b * kLanes; q < std::min(count, (b + 1) * kLanes); ++q)
      slots = std::max(slots, degree(node(q)));
    l.slot_offsets[b + 1] = l.slot_offsets[b] + slots;
  }
  const auto entries = static_cast<size_t>(l.slot_offsets[blocks]) * kLanes;
  if (entries >= 8192) return;
  l.count = count;
  l.own4.resize(static_cast<size_t>(blocks) * kLanes);
  l.other4.resize(entries);
  l.inverse_rest.resize(entries);
  l.k_rest.resize(entries);
  l.entry.resize(entries);
  std::vector<uint8_t> read(static_cast<size_t>(t.nodes), 0);
  for (int32_t b = 0; b < blocks; ++b)
    for (int32_t q = 0; q < kLanes; ++q) {
      const int32_t lane = b * kLanes + q, i = node(lane);
      l.own4[static_cast<size_t>(lane)] = 4 * i;
      read[static_cast<size_t>(i)] = 1;
      for (int32_t k = 0; k < l.slot_offsets[b + 1] - l.slot_offsets[b]; ++k) {
        const auto e = static_cast<size_t>(l.slot_offsets[b] + k) * kLanes + q;
        const bool real = lane < count && k < degree(i);
        const int64_t from =
            real ? (int64_t{t.slot_offsets[i / kLanes]} + k) * kLanes + i % kLanes : -1;
        l.entry[e] = from;
        l.other4[e] = real ? t.other4[static_cast<size_t>(from)] : 4 * i;
        l.inverse_rest[e] = real ? t.inverse_rest[static_cast<size_t>(from)] : 0.0f;
        l.k_rest[e] = real ? t.k_rest[static_cast<size_t>(from)] : 0.0f;
        read[static_cast<size_t>(l.other4[e] / 4)] = 1;
      }
    }
  l.read_nodes.clear();
  for (int32_t i = 0; i < t.nodes; ++i)
    if (read[static_cast<size_t>(i)]) l.read_nodes.push_back(i);
  l.on = true;
}

}  // namespace

void refresh_spring_lanes(Solver& s) {
  SpringLanes& t = s.lanes;
  if (t.nodes != s.model->node_count()) {  // not made: the tetrahedra carry the springs (resolve)
    t.active_blocks.clear();
    t.local.on = false;
    t.local.entry.clear();
    return;
  }
  t.movable.assign(s.movable.begin(), s.movable.end());
  t.active_blocks.clear();
  for (int32_t i : s.active_nodes)
    if (t.active_blocks.empty() || t.active_blocks.back() != i / kLanes)
      t.active_blocks.push_back(i / kLanes);
  t.work_before.assign(1, 0);
  for (int32_t b : t.active_blocks)
    t.work_before.push_back(t.work_before.back() + t.slot_offsets[b + 1] - t.slot_offsets[b] + 2);
  // Implicit Euler's tables (a resize to the same size allocates nothing).
  const bool products = !s.tets.on && s.options.integrator == Integrator::kImplicitEuler;
  const bool sized = !t.stiffness.empty();
  t.product.resize(products ? 4 * t.spring.size() : 0);
  t.packed.resize(products ? 4 * static_cast<size_t>(t.nodes) : 0);
  t.stiffness.resize(products ? t.spring.size() : 0);
  t.force.resize(products ? 3 * static_cast<size_t>(t.nodes) : 0);
  if (products && !sized) fill_spring_lanes(s);
  refresh_local_lanes(s);
  t.reads_all = s.active_nodes.size() * 2 >= static_cast<size_t>(t.nodes);
  t.read_nodes.clear();
  if (t.reads_all) return;  // converting every node is cheaper than listing them
  std::vector<uint8_t> read(static_cast<size_t>(t.nodes), 0);
  for (int32_t b : t.active_blocks) {
    for (int32_t i = b * kLanes; i < std::min(t.nodes, (b + 1) * kLanes); ++i) read[i] = 1;
    for (int64_t e = int64_t{t.slot_offsets[b]} * kLanes;
         e < int64_t{t.slot_offsets[b + 1]} * kLanes; ++e)
      read[t.other4[e] / 4] = 1;
  }
  for (int32_t i = 0; i < t.nodes; ++i)
    if (read[i]) t.read_nodes.push_back(i);
}

}  // namespace lamina::sim::detail
