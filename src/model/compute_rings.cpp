#include "lamina/model/compute_rings.h"

#include <algorithm>

#include "lamina/core/error.h"

namespace lamina::model {
namespace {

// Intra-layer adjacency as CSR (inter-layer springs are not part of a layer's rings).
struct LayerGraph {
  std::vector<int32_t> first;  // #nodes + 1
  std::vector<int32_t> adj;
};

LayerGraph layer_graph(const Model& model) {
  const int32_t n = model.node_count();
  LayerGraph g;
  g.first.assign(static_cast<size_t>(n) + 1, 0);
  const Springs& s = model.springs;
  for (size_t e = 0; e < s.size(); ++e)
    if (s.kind[e] == SpringKind::kIntraLayer) ++g.first[s.i[e] + 1], ++g.first[s.j[e] + 1];
  for (int32_t v = 0; v < n; ++v) g.first[v + 1] += g.first[v];
  g.adj.resize(static_cast<size_t>(g.first[n]));
  std::vector<int32_t> fill(g.first.begin(), g.first.end() - 1);
  for (size_t e = 0; e < s.size(); ++e)
    if (s.kind[e] == SpringKind::kIntraLayer)
      g.adj[fill[s.i[e]]++] = s.j[e], g.adj[fill[s.j[e]]++] = s.i[e];
  return g;
}

// Breadth-first search: appends rings 0..locality-1 of node v. A visit stamp per node avoids
// clearing a visited array for every search.
struct Search {
  std::vector<int32_t> stamp, frontier, next;
  explicit Search(int32_t n) : stamp(static_cast<size_t>(n), -1) {}

  void append(const LayerGraph& g, int32_t v, int32_t locality, Rings& rings) {
    frontier.assign(1, v);
    stamp[v] = v;
    for (int32_t r = 0; r < locality; ++r) {
      if (r > 0) {
        next.clear();
        for (int32_t u : frontier)
          for (int32_t a = g.first[u]; a < g.first[u + 1]; ++a)
            if (stamp[g.adj[a]] != v) stamp[g.adj[a]] = v, next.push_back(g.adj[a]);
        std::sort(next.begin(), next.end());
        frontier.swap(next);
      }
      rings.members.insert(rings.members.end(), frontier.begin(), frontier.end());
      rings.offsets.push_back(static_cast<int64_t>(rings.members.size()));
    }
  }
};

}  // namespace

Rings compute_rings(const Model& model, int32_t locality) {
  if (locality < 1)
    throw invalid_input("locality", "must be at least 1, got " + std::to_string(locality));
  const int32_t n = model.node_count();
  const LayerGraph g = layer_graph(model);
  Rings rings;
  rings.locality = locality;
  rings.offsets.reserve(static_cast<size_t>(n) * locality + 1);
  rings.offsets.push_back(0);
  Search search(n);
  for (int32_t v = 0; v < n; ++v) search.append(g, v, locality, rings);
  rings.members.shrink_to_fit();
  return rings;
}

Rings update_rings(const Model& model, const Rings& previous,
                   const std::vector<int32_t>& previous_node, const std::vector<int32_t>& renumber,
                   const std::vector<uint8_t>& keep) {
  const int32_t n = model.node_count(), locality = previous.locality;
  if (locality < 1)
    throw invalid_input("locality", "must be at least 1, got " + std::to_string(locality));
  // The nodes searched again first (a cut's few, on the new layer graph), then every node's
  // place in the result, then the kept rings copied renumbered on the threads: made again at
  // every cut, this was 8 ms of a 48k-node event on one thread (docs/benchmarks.md).
  Rings searched;
  searched.locality = locality;
  searched.offsets.push_back(0);
  std::vector<int32_t> searched_at(static_cast<size_t>(n), -1);
  if (std::find(keep.begin(), keep.end(), uint8_t{0}) != keep.end()) {
    const LayerGraph g = layer_graph(model);
    Search search(n);
    int32_t k = 0;
    for (int32_t v = 0; v < n; ++v)
      if (!keep[v]) searched_at[v] = k++, search.append(g, v, locality, searched);
  }
  Rings rings;
  rings.locality = locality;
  rings.offsets.resize(static_cast<size_t>(n) * locality + 1);
  rings.offsets[0] = 0;
  for (int32_t v = 0; v < n; ++v)
    for (int32_t r = 0; r < locality; ++r) {
      const int64_t size =
          keep[v] ? previous.ring_size(previous_node[v], r) : searched.ring_size(searched_at[v], r);
      const size_t at = static_cast<size_t>(v) * locality + r;
      rings.offsets[at + 1] = rings.offsets[at] + size;
    }
  rings.members.resize(static_cast<size_t>(rings.offsets.back()));
#pragma omp parallel for schedule(static)
  for (int32_t v = 0; v < n; ++v) {
    const size_t first = static_cast<size_t>(v) * locality;
    int32_t* out = rings.members.data() + rings.offsets[first];
    const int64_t count = rings.offsets[first + locality] - rings.offsets[first];
    if (!keep[v]) {
      std::copy_n(searched.ring(searched_at[v], 0), count, out);
      continue;
    }
    // Renumbering is monotone: each ring stays sorted.
    const int32_t* in = previous.ring(previous_node[v], 0);
    for (int64_t k = 0; k < count; ++k) out[k] = renumber[in[k]];
  }
  return rings;
}

}  // namespace lamina::model
