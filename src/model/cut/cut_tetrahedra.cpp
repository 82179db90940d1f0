// The virtual node algorithm (Molino, Bao & Fedkiw 2004) on the model's tetrahedra: divided
// tetrahedra become two copies; the copies' corners and the whole tetrahedra's corners around
// the cut are glued across the faces where their material meets, and each glued set is a node.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <unordered_set>

#include "cut_internal.h"
#include "lamina/core/error.h"
#include "lamina/model/compute_rings.h"

namespace lamina::model {
namespace {

using detail::Division;

struct UnionFind {
  std::vector<int32_t> parent;
  UnionFind() = default;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int32_t find(int32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void join(int32_t a, int32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

struct FaceKey {
  int32_t a, b, c;  // sorted
  bool operator==(const FaceKey&) const = default;
};
struct FaceHash {
  size_t operator()(const FaceKey& k) const {
    uint64_t h = static_cast<uint32_t>(k.a);
    h = h * 0x9E3779B97F4A7C15ull + static_cast<uint32_t>(k.b);
    h = h * 0x9E3779B97F4A7C15ull + static_cast<uint32_t>(k.c);
    return static_cast<size_t>(h ^ (h >> 29));
  }
};
FaceKey face_key(int32_t a, int32_t b, int32_t c) {
  std::array<int32_t, 3> v{a, b, c};
  std::sort(v.begin(), v.end());
  return {v[0], v[1], v[2]};
}

double rest_volume(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::Vector3d p0 = X.row(T(t, 0));
  return std::abs((X.row(T(t, 1)).transpose() - p0)
                      .cross(X.row(T(t, 2)).transpose() - p0)
                      .dot(X.row(T(t, 3)).transpose() - p0)) /
         6.0;
}

void check_inputs(const Model& model, const Eigen::MatrixX3d& x, const Blade& blade) {
  if (!model.has_tets())
    throw invalid_input("cut",
                        "the model has no tetrahedra (built with --structure links): "
                        "only a model with tetrahedra can be cut");
  if (x.rows() != model.X.rows())
    throw invalid_input("cut", "positions for " + std::to_string(x.rows()) +
                                   " nodes, the model has " + std::to_string(model.X.rows()));
  if (!x.allFinite()) throw invalid_input("cut", "the positions are not all finite");
  if (blade.F.rows() == 0) throw invalid_input("blade", "has no triangles");
  if (!blade.V.allFinite()) throw invalid_input("blade", "has a point that is not finite");
  if (blade.F.size() > 0 && (blade.F.minCoeff() < 0 || blade.F.maxCoeff() >= blade.V.rows()))
    throw invalid_input("blade", "a triangle names a point it does not have");
}

// The copies: one per whole tetrahedron, two per divided one.
struct Copies {
  std::vector<int32_t> tet;
  std::vector<uint8_t> mask;   // the corners whose material it carries (15: all)
  std::vector<double> share;   // its share of the tetrahedron's rest volume
  std::vector<int32_t> first;  // per tetrahedron: its first copy (the next tetrahedron's ends it)
};

// The tetrahedra having a face (and which corner each omits).
struct FaceUse {
  std::array<int32_t, 4> tet{};
  std::array<int, 4> omitted{};
  int n = 0;
};

Copies make_copies(const Model& model, const std::vector<Division>& divided) {
  const Eigen::Index nt = model.tets.size();
  std::vector<int32_t> division(static_cast<size_t>(nt), -1);
  for (size_t k = 0; k < divided.size(); ++k) division[divided[k].tet] = static_cast<int32_t>(k);
  Copies c;
  c.first.resize(static_cast<size_t>(nt) + 1);
  for (Eigen::Index t = 0; t < nt; ++t) {
    c.first[t] = static_cast<int32_t>(c.tet.size());
    const double own = model.tets.share_of(t);
    if (division[t] < 0) {
      c.tet.push_back(static_cast<int32_t>(t)), c.mask.push_back(model.tets.material_of(t));
      c.share.push_back(own);
      continue;
    }
    const Division& d = divided[division[t]];
    c.tet.push_back(static_cast<int32_t>(t)), c.mask.push_back(d.side);
    c.share.push_back(own * d.share);
    c.tet.push_back(static_cast<int32_t>(t)), c.mask.push_back(static_cast<uint8_t>(~d.side & 15));
    c.share.push_back(own * (1.0 - d.share));
  }
  c.first[nt] = static_cast<int32_t>(c.tet.size());
  return c;
}

int corner_of(const Eigen::MatrixX4i& T, int32_t t, int32_t node) {
  for (int k = 0; k < 4; ++k)
    if (T(t, k) == node) return k;
  return -1;
}

// Where the blade divides the model: the blade indexed, its crossings of the edges, and each
// divided tetrahedron with its side (counted in the report, with the structures it crosses).
struct Divisions {
  detail::BladeIndex index;
  detail::Crossings crossings;
  std::vector<Division> divided;
};

Divisions find_divisions(const Model& model, const Eigen::MatrixX3d& x, const Blade& blade,
                         const CutOptions& options, CutReport& report) {
  const Eigen::MatrixX4i& T = model.tets.T;
  Divisions d;
  d.index = detail::index_blade(blade);
  d.crossings = detail::blade_crossings(x, T, d.index);
  // A copy an earlier cut made carries the material on one side of that cut only, which a copy
  // does not record: it is not divided again (a later cut ends at an earlier one's tetrahedra,
  // and a progressive cut sweeps its whole path so far, so that its tip's tetrahedra are
  // divided once the blade has passed through them).
  if (!model.tets.share.empty())
    std::erase_if(d.crossings.near_tets, [&](int32_t t) { return model.tets.share[t] < 1.0; });
  detail::divide_tets(T, d.crossings, d.divided, report.partly_cut_tets);
  if (options.tip_from.allFinite()) {
    const Eigen::AlignedBox3d tip(options.tip_from.cwiseMin(options.tip_to),
                                  options.tip_from.cwiseMax(options.tip_to));
    report.partly_cut_tets += std::erase_if(
        d.divided, [&](const Division& v) { return detail::tet_box(x, T, v.tet).intersects(tip); });
  }
  if (options.find_structures)
    report.structures_cut = detail::structures_crossed(model, x, d.index, d.index.lo, d.index.hi);
  report.cut_tets = static_cast<int64_t>(d.divided.size());
  return d;
}

// The copies and how they are glued: which of their corners are one node, and each node's
// number in the cut model.
struct Glue {
  Copies copies;
  std::vector<uint8_t> affected;  // per node: a corner of a divided tetrahedron
  std::vector<int32_t> star;      // the tetrahedra with a corner there
  std::unordered_map<FaceKey, FaceUse, FaceHash> faces;
  UnionFind slots;  // the copies' corners (4 c + k) glued into nodes
  // The numbering (number_nodes()): a node the cut left alone is first_new of its old number;
  // a glued set of slots is slot_node of its root.
  std::vector<int32_t> first_new, slot_node;

  // The cut model's node at corner k of copy c.
  int32_t new_node(const Eigen::MatrixX4i& T, int32_t c, int k) {
    const int32_t v = T(copies.tet[c], k);
    return affected[v] ? slot_node[slots.find(4 * c + k)] : first_new[v];
  }
};

Glue glue_copies(const Model& model, const std::vector<Division>& divided) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const int32_t n = model.node_count();
  const Eigen::Index nt = model.tets.size();
  Glue g;
  g.copies = make_copies(model, divided);
  const Copies& copies = g.copies;
  const auto ncopies = static_cast<int32_t>(copies.tet.size());
  // The nodes around the cut: the corners of divided tetrahedra. Only their corners are glued;
  // every other node stays one node.
  std::vector<uint8_t>& affected = g.affected;
  affected.assign(static_cast<size_t>(n), 0);
  for (const Division& d : divided)
    for (int k = 0; k < 4; ++k) affected[T(d.tet, k)] = 1;

  // The tetrahedra with a corner there: everything the cut changes is in them.
  std::vector<int32_t>& star = g.star;
  for (Eigen::Index t = 0; t < nt; ++t)
    if (affected[T(t, 0)] || affected[T(t, 1)] || affected[T(t, 2)] || affected[T(t, 3)])
      star.push_back(static_cast<int32_t>(t));

  // Faces with a node around the cut, and the (tetrahedron, omitted corner) pairs that have them.
  // On a model cut before, up to four tetrahedra share a face: where an earlier cut ended, its
  // two copies and the whole tetrahedron beyond its edge that joins them.
  std::unordered_map<FaceKey, FaceUse, FaceHash>& faces = g.faces;
  for (const int32_t t : star) {
    for (int o = 0; o < 4; ++o) {
      const int i = (o + 1) % 4, j = (o + 2) % 4, k = (o + 3) % 4;
      if (!(affected[T(t, i)] || affected[T(t, j)] || affected[T(t, k)])) continue;
      FaceUse& use = faces[face_key(T(t, i), T(t, j), T(t, k))];
      if (use.n == 4)
        throw Error(ErrorKind::kInternal, "cut: more than four tetrahedra share a face");
      use.tet[use.n] = t, use.omitted[use.n] = o, ++use.n;
    }
  }

  // Glue: two copies meeting at a face share its nodes where both carry material on that face
  // and their material there overlaps (the same side of the cut, or a whole tetrahedron).
  g.slots = UnionFind(static_cast<size_t>(ncopies) * 4);
  UnionFind& slots = g.slots;
  auto face_material = [&](int32_t c, int omitted) {
    std::array<int32_t, 3> m{-1, -1, -1};
    int at = 0;
    for (int k = 0; k < 4; ++k)
      if (k != omitted && (copies.mask[c] >> k & 1)) m[at++] = T(copies.tet[c], k);
    // At most three, sorted by insertion: GCC 12 cannot tell that std::sort's heap paths stay
    // inside `m` and warns that they may not (-Warray-bounds).
    for (int a = 1; a < at; ++a)
      for (int b = a; b > 0 && m[b - 1] > m[b]; --b) std::swap(m[b - 1], m[b]);
    return std::pair{m, at};
  };
  for (const auto& [key, use] : faces)
    for (int u1 = 0; u1 < use.n; ++u1)
      for (int u2 = u1 + 1; u2 < use.n; ++u2) {
        const int32_t t1 = use.tet[u1], t2 = use.tet[u2];
        const int o1 = use.omitted[u1], o2 = use.omitted[u2];
        for (int32_t c1 = copies.first[t1]; c1 < copies.first[t1 + 1]; ++c1) {
          const auto [m1, n1] = face_material(c1, o1);
          for (int32_t c2 = copies.first[t2]; c2 < copies.first[t2 + 1]; ++c2) {
            const auto [m2, n2] = face_material(c2, o2);
            bool meet = false;
            for (int a = 0; a < n1; ++a)
              for (int b = 0; b < n2; ++b) meet = meet || m1[a] == m2[b];
            if (!meet) continue;
            for (int k = 0; k < 4; ++k) {
              if (k == o1 || !affected[T(t1, k)]) continue;
              slots.join(4 * c1 + k, 4 * c2 + corner_of(T, t2, T(t1, k)));
            }
          }
        }
      }
  return g;
}

// Each glued set of an affected node's slots is a node: numbered after the node's place, the
// one carrying the most material first, so layers stay contiguous ranges. Returns the nodes'
// masses; `origin` each new node's old one.
std::vector<double> number_nodes(const Model& model, Glue& g, std::vector<int32_t>& origin) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const int32_t n = model.node_count();
  const Copies& copies = g.copies;
  const auto ncopies = static_cast<int32_t>(copies.tet.size());
  const std::vector<uint8_t>& affected = g.affected;
  std::vector<double> slot_weight(static_cast<size_t>(ncopies) * 4, 0.0);
  std::vector<std::vector<int32_t>> node_slots(static_cast<size_t>(n));
  for (const int32_t t : g.star)
    for (int32_t c = copies.first[t]; c < copies.first[t + 1]; ++c) {
      const double w = copies.share[c] * rest_volume(model.X, T, t);
      for (int k = 0; k < 4; ++k) {
        const int32_t v = T(t, k);
        if (!affected[v]) continue;
        node_slots[v].push_back(4 * c + k);
        slot_weight[4 * c + k] = w;
      }
    }
  std::vector<int32_t>& first_new = g.first_new;
  first_new.assign(static_cast<size_t>(n) + 1, 0);
  std::vector<int32_t>& slot_node = g.slot_node;
  slot_node.assign(static_cast<size_t>(ncopies) * 4, -1);
  origin.clear();
  std::vector<double> new_mass;
  for (int32_t v = 0; v < n; ++v) {
    first_new[v] = static_cast<int32_t>(origin.size());
    if (!affected[v]) {
      origin.push_back(v);
      new_mass.push_back(model.mass_kg[v]);
      continue;
    }
    std::vector<std::pair<int32_t, double>> classes;  // root, weight
    for (int32_t sl : node_slots[v]) {
      const int32_t r = g.slots.find(sl);
      auto it = std::find_if(classes.begin(), classes.end(), [&](auto& p) { return p.first == r; });
      if (it == classes.end())
        classes.emplace_back(r, slot_weight[sl]);
      else
        it->second += slot_weight[sl];
    }
    std::sort(classes.begin(), classes.end(), [](auto& p, auto& q) {
      return p.second != q.second ? p.second > q.second : p.first < q.first;
    });
    double total = 0.0;
    for (auto& [r, w] : classes) total += w;
    // Each copy's part of the node's mass is the material it carries, but no copy takes less
    // than kMinCopyMass of it (the heavier ones give it up in proportion, so the node's mass is
    // kept exactly): a copy with a sliver's mass never came to rest.
    const auto k = static_cast<double>(classes.size());
    const double floor = std::min(kMinCopyMass, 0.5 / k);
    std::vector<double> part(classes.size());
    double light = 0.0, heavy = 0.0;
    for (size_t c = 0; c < classes.size(); ++c) {
      part[c] = total > 0.0 ? classes[c].second / total : 1.0 / k;
      (part[c] < floor ? light : heavy) += part[c] < floor ? floor : part[c];
    }
    for (size_t c = 0; c < classes.size(); ++c) {
      if (part[c] < floor)
        part[c] = floor;
      else if (heavy > 0.0)
        part[c] *= (1.0 - light) / heavy;
      slot_node[classes[c].first] = static_cast<int32_t>(origin.size());
      origin.push_back(v);
      new_mass.push_back(model.mass_kg[v] * part[c]);
    }
  }
  first_new[n] = static_cast<int32_t>(origin.size());
  return new_mass;
}

// The cut model's nodes (at their old nodes' rest positions, layers and fixing) and its
// tetrahedra: every copy, at its tetrahedron's corners' new nodes.
void copy_nodes_and_tets(const Model& model, Glue& g, const std::vector<int32_t>& origin,
                         std::vector<double> new_mass, bool divided_any, Model& m) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const Copies& copies = g.copies;
  const auto ncopies = static_cast<int32_t>(copies.tet.size());
  const auto nn = static_cast<int32_t>(origin.size());
  m.density_kg_per_mm3 = model.density_kg_per_mm3;
  m.source = model.source;
  m.X.resize(nn, 3);
  m.layer_of.resize(static_cast<size_t>(nn));
  m.fixed.resize(static_cast<size_t>(nn));
  for (int32_t i = 0; i < nn; ++i) {
    m.X.row(i) = model.X.row(origin[i]);
    m.layer_of[i] = model.layer_of[origin[i]];
    m.fixed[i] = model.fixed.empty() ? 0 : model.fixed[origin[i]];
  }
  m.mass_kg = std::move(new_mass);

  m.tets.T.resize(ncopies, 4);
  m.tets.region.resize(static_cast<size_t>(ncopies));
  m.tets.share = copies.share;
  m.tets.material = copies.mask;
  for (int32_t c = 0; c < ncopies; ++c) {
    for (int k = 0; k < 4; ++k) m.tets.T(c, k) = g.new_node(T, c, k);
    m.tets.region[c] = model.tets.region[copies.tet[c]];
  }
  if (!divided_any && model.tets.share.empty()) m.tets.share.clear(), m.tets.material.clear();
}

// Springs. One between two nodes the cut left alone keeps its place (the renumbering is
// monotone, so they stay sorted); the edges at the glued nodes are made again from the copies
// of the tetrahedra around them, each with the part of its edge's constant that its copies'
// shares carry.
void cut_springs(const Model& model, Glue& g, bool divided_any, Model& m) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const Copies& copies = g.copies;
  const std::vector<uint8_t>& affected = g.affected;
  const std::vector<int32_t>& first_new = g.first_new;
  const auto nn = static_cast<int32_t>(m.X.rows());
  const Springs& sp = model.springs;
  std::vector<double> edge_total(sp.size(), 0.0);
  for (const int32_t t : g.star)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (affected[T(t, i)] || affected[T(t, j)]) {
          const int32_t e = detail::find_spring(sp, T(t, i), T(t, j));
          if (e >= 0) edge_total[e] += model.tets.share_of(t);
        }
  struct NewEdge {
    int32_t i, j, spring;
    double share;
  };
  std::vector<NewEdge> edges;
  for (const int32_t t : g.star)
    for (int32_t c = copies.first[t]; c < copies.first[t + 1]; ++c)
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
          if (!(affected[T(t, i)] || affected[T(t, j)])) continue;
          const int32_t e = detail::find_spring(sp, T(t, i), T(t, j));
          if (e < 0) continue;
          const int32_t p = g.new_node(T, c, i), q = g.new_node(T, c, j);
          edges.push_back({std::min(p, q), std::max(p, q), e, copies.share[c]});
        }
  // A spring at a glued node that is no tetrahedron's edge (none in a model built with
  // tetrahedra) joins its nodes' first copies.
  for (size_t e = 0; e < sp.size(); ++e)
    if ((affected[sp.i[e]] || affected[sp.j[e]]) && edge_total[e] == 0.0)
      edges.push_back({first_new[sp.i[e]], first_new[sp.j[e]], static_cast<int32_t>(e), 0.0});
  std::sort(edges.begin(), edges.end(),
            [](const NewEdge& a, const NewEdge& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  const bool shared = divided_any || !sp.share.empty();
  auto add_spring = [&](int32_t i, int32_t j, size_t e, double part) {
    m.springs.i.push_back(i);
    m.springs.j.push_back(j);
    m.springs.rest_length_mm.push_back(sp.rest_length_mm[e]);
    m.springs.stiffness_n_per_m.push_back(sp.stiffness_n_per_m[e] * part);
    m.springs.kind.push_back(sp.kind[e]);
    if (shared) m.springs.share.push_back(sp.share_of(e) * part);
  };
  // Merge the kept springs (in their order) with the new edges (sorted, each pair once).
  size_t k = 0;
  auto add_new_up_to = [&](int32_t i, int32_t j) {
    while (k < edges.size() && (edges[k].i < i || (edges[k].i == i && edges[k].j < j))) {
      size_t end = k;
      double carried = 0.0;
      while (end < edges.size() && edges[end].i == edges[k].i && edges[end].j == edges[k].j)
        carried += edges[end++].share;
      const auto e = static_cast<size_t>(edges[k].spring);
      // At most all of it: the two sums add the same shares in different orders, and an edge
      // the cut did not divide must keep exactly its constant (not 1 + 2e-16 of it).
      add_spring(edges[k].i, edges[k].j, e,
                 edge_total[e] > 0.0 ? std::min(1.0, carried / edge_total[e]) : 1.0);
      k = end;
    }
  };
  for (size_t e = 0; e < sp.size(); ++e) {
    if (affected[sp.i[e]] || affected[sp.j[e]]) continue;
    const int32_t i = first_new[sp.i[e]], j = first_new[sp.j[e]];
    add_new_up_to(i, j);
    add_spring(i, j, e, 1.0);
  }
  add_new_up_to(nn, nn);
}

// Layers: each triangle on the copies of its tetrahedron (the one inside the layer) that carry
// material on it: a triangle the cut divides is on both sides' copies.
void cut_layers(const Model& model, Glue& g, Model& m) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const Copies& copies = g.copies;
  const std::vector<uint8_t>& affected = g.affected;
  const std::vector<int32_t>& first_new = g.first_new;
  for (size_t k = 0; k < model.layers.size(); ++k) {
    const ModelLayer& l = model.layers[k];
    ModelLayer nl;
    nl.first_node = first_new[l.first_node];
    nl.node_count = first_new[l.first_node + l.node_count] - nl.first_node;
    std::vector<Eigen::Vector3i> tris;
    tris.reserve(static_cast<size_t>(l.F.rows()));
    std::unordered_set<FaceKey, FaceHash> made;  // each triangle once (see below)
    for (Eigen::Index f = 0; f < l.F.rows(); ++f) {
      const int32_t a = l.F(f, 0), b = l.F(f, 1), c = l.F(f, 2);
      if (!(affected[a] || affected[b] || affected[c])) {
        tris.emplace_back(first_new[a], first_new[b], first_new[c]);
        continue;
      }
      const auto it = g.faces.find(face_key(a, b, c));
      if (it == g.faces.end())
        throw Error(ErrorKind::kInternal, "cut: layer " + std::to_string(k) + " triangle " +
                                              std::to_string(f) + " is no tetrahedron's face");
      // The tetrahedra inside the layer (those of the shell it bounds; for the skin, all), on
      // each copy of them that carries material on the triangle. Where an earlier cut ended,
      // two copies and the one joining them carry it at the same nodes: once is enough.
      const FaceUse& use = it->second;
      bool inside = false;
      for (int u = 0; u < use.n; ++u)
        inside = inside || model.tets.region[use.tet[u]] == static_cast<int32_t>(k);
      for (int u = 0; u < use.n; ++u) {
        const int32_t t = use.tet[u], o = use.omitted[u];
        if (inside && model.tets.region[t] != static_cast<int32_t>(k)) continue;
        for (int32_t cp = copies.first[t]; cp < copies.first[t + 1]; ++cp) {
          bool carries = false;
          for (int q = 0; q < 4; ++q) carries = carries || (q != o && (copies.mask[cp] >> q & 1));
          if (!carries) continue;
          const Eigen::Vector3i tri(g.new_node(T, cp, corner_of(T, t, a)),
                                    g.new_node(T, cp, corner_of(T, t, b)),
                                    g.new_node(T, cp, corner_of(T, t, c)));
          if (made.insert(face_key(tri[0], tri[1], tri[2])).second) tris.push_back(tri);
        }
      }
    }
    nl.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
    for (size_t r = 0; r < tris.size(); ++r) nl.F.row(static_cast<Eigen::Index>(r)) = tris[r];
    m.layers.push_back(std::move(nl));
  }
}

// Rings: a node whose rings reach no glued node keeps them (renumbered); the others are
// searched again.
void cut_rings(const Model& model, const Glue& g, const std::vector<int32_t>& origin, Model& m) {
  if (model.rings.locality <= 0) return;
  const int32_t n = model.node_count();
  const auto nn = static_cast<int32_t>(origin.size());
  // A node's rings reach an affected node exactly when it lies in that node's rings (within
  // locality - 1 steps either way): the affected nodes' rings, not every node's, are read.
  std::vector<uint8_t> reaches(static_cast<size_t>(n), 0);
  for (int32_t u = 0; u < n; ++u) {
    if (!g.affected[u]) continue;
    const int64_t end = model.rings.offsets[static_cast<size_t>(u + 1) * model.rings.locality];
    for (int64_t q = model.rings.offsets[static_cast<size_t>(u) * model.rings.locality]; q < end;
         ++q)
      reaches[static_cast<size_t>(model.rings.members[q])] = 1;
  }
  std::vector<uint8_t> keep(static_cast<size_t>(nn));
  for (int32_t i = 0; i < nn; ++i) keep[i] = !reaches[origin[i]];
  m.rings = update_rings(m, model.rings, origin, g.first_new, keep);
}

// Which tetrahedron an embedded vertex's corners name. (At an earlier cut's tip both copies of a
// tetrahedron can have the same four nodes, glued to the whole tetrahedra beyond, until a later
// cut parts them: of those, the copy on the side of the point q at rest, the vertex's. A
// progressive cut sweeps the earlier cut's surface again: the side is the blade's there;
// elsewhere, the copy whose material corners carry more of the point's weights.)
class TetFinder {
 public:
  TetFinder(const Model& model, const std::vector<int32_t>& star,
            const std::vector<Division>& divided, const detail::BladeIndex& rest_index)
      : model_(model), T_(model.tets.T), rest_index_(rest_index) {
    for (const Division& d : divided)
      reach_ = std::max(reach_, (model.X.row(T_(d.tet, 1)) - model.X.row(T_(d.tet, 0))).norm());
    for (const int32_t t : star) {
      std::array<int32_t, 4> u{T_(t, 0), T_(t, 1), T_(t, 2), T_(t, 3)};
      std::sort(u.begin(), u.end());
      tets_at_[detail::edge_key(u[0], u[1])].push_back(t);
    }
  }

  // The barycentric coordinates of q at rest in tetrahedron t.
  Eigen::Vector4d weights_at(int32_t t, const Eigen::Vector3d& q) const {
    Eigen::Matrix3d D;
    for (int k = 1; k < 4; ++k)
      D.col(k - 1) = (model_.X.row(T_(t, k)) - model_.X.row(T_(t, 0))).transpose();
    const Eigen::Vector3d l = D.fullPivLu().solve(q - model_.X.row(T_(t, 0)).transpose());
    return Eigen::Vector4d(1.0 - l.sum(), l[0], l[1], l[2]);
  }

  // The tetrahedron with these corners (and q's side of it, see above); -1: none.
  int32_t tet_of(const std::array<int32_t, 4>& corners, const Eigen::Vector3d& q) const {
    std::array<int32_t, 4> s = corners;
    std::sort(s.begin(), s.end());
    const auto it = tets_at_.find(detail::edge_key(s[0], s[1]));
    if (it == tets_at_.end()) return -1;
    std::array<int32_t, 2> found{-1, -1};
    int n = 0;
    for (int32_t t : it->second) {
      std::array<int32_t, 4> u{T_(t, 0), T_(t, 1), T_(t, 2), T_(t, 3)};
      std::sort(u.begin(), u.end());
      if (u == s && n < 2) found[n++] = t;
    }
    if (n < 2) return found[0];
    const int k = detail::blade_triangle_at(rest_index_, q, reach_);
    if (k >= 0) {
      const detail::BladeTriangle& b = rest_index_.tris[static_cast<size_t>(k)];
      const bool above = b.n.dot(q - b.p0) > 0.0;
      for (const int32_t t : found)
        if ((b.n.dot(detail::material_centre(model_.X, T_, model_.tets, t) - b.p0) > 0.0) == above)
          return t;
    }
    double on[2] = {0.0, 0.0};
    for (int c = 0; c < 2; ++c) {
      const Eigen::Vector4d w = weights_at(found[c], q);
      for (int j = 0; j < 4; ++j)
        if (model_.tets.material_of(found[c]) >> j & 1) on[c] += w[j];
    }
    return on[0] >= on[1] ? found[0] : found[1];
  }

 private:
  const Model& model_;
  const Eigen::MatrixX4i& T_;
  const detail::BladeIndex& rest_index_;
  double reach_ = 0.0;
  std::unordered_map<uint64_t, std::vector<int32_t>> tets_at_;  // by their lowest two nodes
};

// A point's side of the cut in divided tetrahedron t (`side` its division's), from its
// barycentric coordinates there: in barycentric space (an affine image of the tetrahedron, which
// keeps sides of planes) the cut is the plane through its crossings of the edges (for two and
// two, the best plane through the four). True when on `side`.
bool on_side(const Eigen::MatrixX4i& T, const detail::Crossings& crossings, int32_t t, uint8_t side,
             const Eigen::Vector4d& bary) {
  const Eigen::Vector3d corner[4] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                     Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 4> p;
  std::array<int, 4> from{}, to{};
  int np = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if ((side >> i & 1) && !(side >> j & 1)) {
        const double f = crossings.fraction(T(t, i), T(t, j));
        from[np] = i, to[np] = j;
        p[np++] = (1.0 - f) * corner[i] + f * corner[j];
      }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), normal;
  for (int k = 0; k < np; ++k) centre += p[k] / np;
  if (np == 3) {
    normal = (p[1] - p[0]).cross(p[2] - p[0]);
  } else {
    // Two and two (a, b | c, d): the crossings in order around the quad are ac, bc, bd, ad.
    auto at = [&](int i, int j) {
      for (int k = 0; k < 4; ++k)
        if (from[k] == i && to[k] == j) return p[k];
      return p[0];
    };
    // (The loops above found them in the order ac, ad, bc, bd.)
    const int a = from[0], b = from[3], c = to[0], d = to[1];
    normal = (at(b, d) - at(a, c)).cross(at(a, d) - at(b, c));
  }
  int inside = 0;
  for (int k = 0; k < 4; ++k)
    if (side >> k & 1) inside = k;
  const Eigen::Vector3d q = bary[0] * corner[0] + bary[1] * corner[1] + bary[2] * corner[2];
  return (normal.dot(q - centre) > 0.0) == (normal.dot(corner[inside] - centre) > 0.0);
}

// The surface s was before the scalpel began (the same name and label, its vertices s's first
// rows), or null.
const EmbeddedSurface* unsplit_of(const CutOptions& options, const EmbeddedSurface& s) {
  if (s.role == SurfaceRole::kWound) return nullptr;
  for (const EmbeddedSurface& u : *options.unsplit)
    if (u.name == s.name && u.role == s.role && u.label == s.label && u.V.rows() <= s.V.rows())
      return &u;
  return nullptr;
}

// A cut that sweeps again (CutOptions::unsplit): each fine surface as it was before the cut
// began, its vertices where the model's now are embedded, to be split along the whole blade.
void take_unsplit(const CutOptions& options, std::vector<EmbeddedSurface>& embedded) {
  for (EmbeddedSurface& s : embedded)
    if (const EmbeddedSurface* u = unsplit_of(options, s)) detail::unsplit_like(*u, s);
}

// Embedded surfaces: a vertex in a divided tetrahedron follows the copy on its side of the cut
// (the plane through the cut's crossings of the tetrahedron's edges, at rest). The fine
// surfaces are split exactly along the blade at rest first (their new vertices told their side
// by a point on their own triangles), then each vertex follows its copy.
// Returns whether the fine surfaces were split though no tetrahedron was divided: a progressive
// scalpel (options.unsplit) whose blade, past the tissue, crosses a structure beside it (the
// tissue divided at earlier events, the structure's part beyond it never split: it stretched
// across the opening between the pieces).
bool follow_embedded(const Model& model, const Eigen::MatrixX3d& x, const Blade& blade,
                     const CutOptions& options, const Divisions& d, Glue& g, Model& m) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const std::vector<Division>& divided = d.divided;
  Blade rest_blade = blade;
  const bool progressive = options.unsplit && options.unsplit_blade;
  if ((!divided.empty() || progressive) && x != model.X) rest_blade.V = to_rest(model, x, blade.V);
  const bool outside =
      divided.empty() && progressive &&
      detail::crosses_fine_surfaces(model.embedded, detail::index_blade(rest_blade));
  const bool afresh = progressive && (!divided.empty() || outside);
  const detail::BladeIndex rest_index =
      detail::index_blade(afresh ? *options.unsplit_blade : rest_blade);
  const TetFinder finder(model, g.star, divided, rest_index);
  std::vector<int32_t> division_of(static_cast<size_t>(model.tets.size()), -1);
  for (size_t k = 0; k < divided.size(); ++k) division_of[divided[k].tet] = static_cast<int32_t>(k);
  m.embedded = model.embedded;
  // Along the path's new part only where it is known (the surfaces split along the rest at the
  // earlier events); else afresh along the whole path.
  std::vector<detail::Resplit> resplit;
  const bool along_new_part = afresh && options.unsplit_new != nullptr;
  const detail::BladeIndex fresh_index =
      along_new_part ? detail::index_blade(*options.unsplit_new) : detail::BladeIndex{};
  if (along_new_part) {
    resplit.resize(m.embedded.size());
    // (Each surface by one thread: its own, the blades read only.)
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t e = 0; e < m.embedded.size(); ++e)
      if (const EmbeddedSurface* u = unsplit_of(options, m.embedded[e])) {
        resplit[e] = detail::drop_resplit_part(*u, rest_index, fresh_index, m.embedded[e]);
        resplit[e].fresh = &fresh_index;
      }
  } else if (afresh) {
    take_unsplit(options, m.embedded);
  }
  std::vector<Eigen::Index> had(m.embedded.size()), made(m.embedded.size());
  for (size_t e = 0; e < m.embedded.size(); ++e) had[e] = m.embedded[e].V.rows();
  const auto hints = detail::split_embedded(model.X, model.tets, g.star, divided,
                                            afresh ? *options.unsplit_blade : rest_blade,
                                            rest_index, m.embedded, outside, resplit, &had);
  for (size_t e = 0; e < m.embedded.size(); ++e)
    made[e] = e < resplit.size() && resplit[e].unsplit ? resplit[e].unsplit->V.rows() : had[e];
  const std::vector<uint8_t>& affected = g.affected;
  // Each vertex (or a tree's seed) to the copy of its tetrahedron on its side.
  const auto relocate = [&](EmbeddedSurface& s, Eigen::Index v, const Eigen::Vector3d* hint) {
    const std::array<int32_t, 4> cs{s.corners(v, 0), s.corners(v, 1), s.corners(v, 2),
                                    s.corners(v, 3)};
    if (!(affected[cs[0]] || affected[cs[1]] || affected[cs[2]] || affected[cs[3]])) {
      for (int k = 0; k < 4; ++k) s.corners(v, k) = g.first_new[cs[k]];
      return;
    }
    // A vertex the split made lies on the cut: its side is its triangles' (a point on them).
    const Eigen::Vector3d q = hint ? *hint : Eigen::Vector3d(s.V.row(v).transpose());
    const int32_t t = finder.tet_of(cs, q);
    if (t < 0)
      throw Error(ErrorKind::kInternal, "cut: " + s.name + " vertex " + std::to_string(v) +
                                            " names corners that are no tetrahedron");
    Eigen::Vector4d bary = Eigen::Vector4d::Zero();
    // A vertex far outside follows its weights' point by an offset: its side is its own
    // point's, not that one's (a gallbladder beside a liver cut through went to the other
    // piece).
    const bool offset = s.offsets.rows() > 0 && !s.offsets.row(v).isZero();
    if (hint || offset) {
      bary = finder.weights_at(t, q);
    } else {
      for (int k = 0; k < 4; ++k) bary[corner_of(T, t, cs[k])] = s.weights(v, k);
    }
    int32_t c = g.copies.first[t];
    if (division_of[t] >= 0 && !on_side(T, d.crossings, t, divided[division_of[t]].side, bary)) ++c;
    for (int k = 0; k < 4; ++k) s.corners(v, k) = g.new_node(T, c, corner_of(T, t, cs[k]));
  };
  for (size_t e = 0; e < m.embedded.size(); ++e)
    for (Eigen::Index v = 0; v < m.embedded[e].corners.rows(); ++v) {
      const bool hinted = static_cast<size_t>(v) < hints[e].size() && hints[e][v].allFinite();
      relocate(m.embedded[e], v, hinted ? &hints[e][v] : nullptr);
    }
  // The vessel trees' seeds: points, never split.
  m.trees = model.trees;
  for (ModelVesselTree& tree : m.trees)
    for (Eigen::Index v = 0; v < tree.seeds.corners.rows(); ++v) relocate(tree.seeds, v, nullptr);
  detail::close_sections(m.embedded, had, rest_index, &made);
  // The wound: each side's cut surface, on the copies of that side.
  std::vector<int32_t> first_copy(divided.size());
  for (size_t k = 0; k < divided.size(); ++k) first_copy[k] = g.copies.first[divided[k].tet];
  detail::add_wound(model.X, T, divided, first_copy, d.crossings, m.tets.T, m.embedded);
  return outside;
}

// Pieces: the connected parts of the copies, the largest first.
void count_pieces(const Model& model, const Copies& copies, const Model& m, CutReport& report) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const auto ncopies = static_cast<int32_t>(copies.tet.size());
  const auto nn = static_cast<int32_t>(m.X.rows());
  UnionFind parts(static_cast<size_t>(nn));
  for (int32_t c = 0; c < ncopies; ++c)
    for (int k = 1; k < 4; ++k) parts.join(m.tets.T(c, 0), m.tets.T(c, k));
  // Each root's piece (-1: none yet), by node: a hash map here was 2 ms of a 48k-node event.
  std::vector<int32_t> piece_of(static_cast<size_t>(nn), -1);
  for (int32_t c = 0; c < ncopies; ++c) {
    int32_t& at = piece_of[static_cast<size_t>(parts.find(m.tets.T(c, 0)))];
    if (at < 0) at = static_cast<int32_t>(report.pieces.size()), report.pieces.emplace_back();
    CutPiece& p = report.pieces[static_cast<size_t>(at)];
    p.volume_mm3 += copies.share[c] * rest_volume(model.X, T, copies.tet[c]);
    ++p.tets;
  }
  for (int32_t i = 0; i < nn; ++i) {
    const int32_t at = piece_of[static_cast<size_t>(parts.find(i))];
    if (at < 0) continue;  // a node of no tetrahedron
    report.pieces[static_cast<size_t>(at)].mass_kg += m.mass_kg[i];
    ++report.pieces[static_cast<size_t>(at)].nodes;
  }
  std::sort(report.pieces.begin(), report.pieces.end(),
            [](const CutPiece& a, const CutPiece& b) { return a.volume_mm3 > b.volume_mm3; });
}

}  // namespace

void cut_tetrahedra(const Model& model, const Eigen::MatrixX3d& x, const Blade& blade, Model& out,
                    std::vector<int32_t>& origin, CutReport& report, const CutOptions& options) {
  check_inputs(model, x, blade);
  report = CutReport{};
  const Divisions d = find_divisions(model, x, blade, options, report);
  Glue g = glue_copies(model, d.divided);
  std::vector<double> new_mass = number_nodes(model, g, origin);
  report.new_nodes = static_cast<int64_t>(origin.size()) - model.node_count();
  Model m;
  copy_nodes_and_tets(model, g, origin, std::move(new_mass), !d.divided.empty(), m);
  cut_springs(model, g, !d.divided.empty(), m);
  cut_layers(model, g, m);
  cut_rings(model, g, origin, m);
  report.surfaces_split = follow_embedded(model, x, blade, options, d, g, m);
  count_pieces(model, g.copies, m, report);
  out = std::move(m);
}

}  // namespace lamina::model
