#include "lamina/model/compute_rings.h"

#include <algorithm>

#include "lamina/core/error.h"

namespace lamina::model {

Rings compute_rings(const Model& model, int32_t locality) {
  if (locality < 1)
    throw invalid_input("locality", "must be at least 1, got " + std::to_string(locality));
  const int32_t n = model.node_count();
  // Intra-layer adjacency as CSR (inter-layer springs are not part of a layer's rings).
  std::vector<int32_t> degree(static_cast<size_t>(n) + 1, 0);
  const Springs& s = model.springs;
  for (size_t e = 0; e < s.size(); ++e)
    if (s.kind[e] == SpringKind::kIntraLayer) ++degree[s.i[e] + 1], ++degree[s.j[e] + 1];
  for (int32_t v = 0; v < n; ++v) degree[v + 1] += degree[v];
  std::vector<int32_t> adj(static_cast<size_t>(degree[n]));
  std::vector<int32_t> fill(degree.begin(), degree.end() - 1);
  for (size_t e = 0; e < s.size(); ++e)
    if (s.kind[e] == SpringKind::kIntraLayer)
      adj[fill[s.i[e]]++] = s.j[e], adj[fill[s.j[e]]++] = s.i[e];

  Rings rings;
  rings.locality = locality;
  rings.offsets.reserve(static_cast<size_t>(n) * locality + 1);
  rings.offsets.push_back(0);
  // A visit stamp per node avoids clearing a visited array for every BFS.
  std::vector<int32_t> stamp(static_cast<size_t>(n), -1);
  std::vector<int32_t> frontier, next;
  for (int32_t v = 0; v < n; ++v) {
    frontier.assign(1, v);
    stamp[v] = v;
    for (int32_t r = 0; r < locality; ++r) {
      if (r > 0) {
        next.clear();
        for (int32_t u : frontier)
          for (int32_t a = degree[u]; a < degree[u + 1]; ++a)
            if (stamp[adj[a]] != v) stamp[adj[a]] = v, next.push_back(adj[a]);
        std::sort(next.begin(), next.end());
        frontier.swap(next);
      }
      rings.members.insert(rings.members.end(), frontier.begin(), frontier.end());
      rings.offsets.push_back(static_cast<int64_t>(rings.members.size()));
    }
  }
  rings.members.shrink_to_fit();
  return rings;
}

}  // namespace lamina::model
