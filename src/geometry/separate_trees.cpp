// Splitting a merged vessel graph into the portal and hepatic trees (separate_trees.h): the two
// trunks found on the organ's anatomy, a minimum cut between them by Boost.Graph's
// Boykov-Kolmogorov maximum flow, stray pieces given to the nearer tree.
#include "lamina/geometry/separate_trees.h"

#include <algorithm>
// GCC 12 warns of a maybe-uninitialized optional inside Boost.Graph's edge iterator (a false
// positive of its inliner in Boost 1.74's header, not this file's code).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/boykov_kolmogorov_max_flow.hpp>
#pragma GCC diagnostic pop
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"
#include "lamina/geometry/vessel_tree.h"
#include "vessel_internal.h"

namespace lamina::geometry {
namespace {

// How strongly a node leans to the tree its branches point at, against its branches' joins.
constexpr double kLeaning = 0.5;

using Traits = boost::adjacency_list_traits<boost::vecS, boost::vecS, boost::directedS>;
using FlowGraph = boost::adjacency_list<
    boost::vecS, boost::vecS, boost::directedS,
    boost::property<boost::vertex_index_t, int32_t,
                    boost::property<boost::vertex_color_t, boost::default_color_type,
                                    boost::property<boost::vertex_distance_t, int64_t,
                                                    boost::property<boost::vertex_predecessor_t,
                                                                    Traits::edge_descriptor>>>>,
    boost::property<
        boost::edge_capacity_t, double,
        boost::property<boost::edge_residual_capacity_t, double,
                        boost::property<boost::edge_reverse_t, Traits::edge_descriptor>>>>;

// An undirected edge of capacity c as two directed ones, each the other's reverse.
void add_both_ways(FlowGraph& g, int32_t a, int32_t b, double c) {
  auto capacity = boost::get(boost::edge_capacity, g);
  auto reverse = boost::get(boost::edge_reverse, g);
  const auto ab = boost::add_edge(static_cast<size_t>(a), static_cast<size_t>(b), g).first;
  const auto ba = boost::add_edge(static_cast<size_t>(b), static_cast<size_t>(a), g).first;
  capacity[ab] = capacity[ba] = c;
  reverse[ab] = ba;
  reverse[ba] = ab;
}

// The branches whose nodes are both `side`, with their nodes renumbered.
VesselGraph subgraph(const VesselGraph& g, const std::vector<uint8_t>& side_of, uint8_t side) {
  VesselGraph out;
  out.frame = g.frame;
  std::vector<int32_t> renumbered(g.nodes.size(), -1);
  for (size_t n = 0; n < g.nodes.size(); ++n)
    if (side_of[n] == side) {
      renumbered[n] = static_cast<int32_t>(out.nodes.size());
      out.nodes.push_back(g.nodes[n]);
      out.nodes.back().degree = 0;
    }
  for (const VesselGraph::Branch& b : g.branches) {
    const int32_t a = renumbered[static_cast<size_t>(b.a)],
                  c = renumbered[static_cast<size_t>(b.b)];
    if (a < 0 || c < 0) continue;
    VesselGraph::Branch nb = b;
    nb.a = a;
    nb.b = c;
    ++out.nodes[static_cast<size_t>(a)].degree;
    ++out.nodes[static_cast<size_t>(c)].degree;
    out.branches.push_back(std::move(nb));
  }
  return out;
}

}  // namespace

SeparatedTrees separate_trees(VesselGraph g, const Mask& organ, const std::string& name) {
  bridge_gaps(g, VesselTreeOptions{}.max_gap_mm);
  const size_t n_nodes = g.nodes.size();

  // The organ's height (physical z: superior), and each node's widest branch.
  const GridFrame& f = organ.frame;
  const detail::Heights heights = detail::organ_heights(organ);
  const auto at_height = [&](double z) { return heights.share(z); };
  const std::vector<double> widest = detail::widest_branch_at_nodes(g);
  const double voxel_mm = std::max({f.spacing_mm[0], f.spacing_mm[1], f.spacing_mm[2]});
  int32_t hepatic = -1;
  for (size_t n = 0; n < n_nodes; ++n) {
    if (widest[n] <= 0.0 || at_height(g.nodes[n].position_mm.z()) < 0.75) continue;
    if (hepatic >= 0 && widest[static_cast<size_t>(hepatic)] >= widest[n]) continue;
    if (detail::near_outside(organ, g.nodes[n].position_mm, widest[n] + 2.0 * voxel_mm))
      hepatic = static_cast<int32_t>(n);
  }
  // The portal vein's: the widest, most nearly horizontal branch in the middle.
  int32_t portal = -1;
  double best = 0.0;
  for (size_t b = 0; b < g.branches.size(); ++b) {
    const VesselGraph::Branch& br = g.branches[b];
    const Eigen::Vector3d d = g.nodes[static_cast<size_t>(br.b)].position_mm -
                              g.nodes[static_cast<size_t>(br.a)].position_mm;
    const double length = d.norm();
    const double h = at_height(0.5 * (g.nodes[static_cast<size_t>(br.a)].position_mm.z() +
                                      g.nodes[static_cast<size_t>(br.b)].position_mm.z()));
    if (length <= 0.0 || h < 0.3 || h > 0.8 || br.a == hepatic || br.b == hepatic) continue;
    const double score =
        br.radius_mm * br.radius_mm * length * std::pow(1.0 - std::abs(d.z()) / length, 4);
    if (score > best) best = score, portal = static_cast<int32_t>(b);
  }
  if (hepatic < 0)
    throw invalid_input(name,
                        "the portal vein and hepatic veins cannot be separated: no hepatic-vein "
                        "trunk reaches the organ's surface in its upper quarter (give them as "
                        "two labels)");
  if (portal < 0)
    throw invalid_input(name,
                        "the portal vein and hepatic veins cannot be separated: no portal-vein "
                        "branch across the organ's middle (give them as two labels)");

  // A binary labelling of the nodes by minimum cut (Boykov and Kolmogorov's energy): each
  // branch joins its nodes with its cross-section (a false contact is thin: cheap to cut); each
  // node leans to the tree whose hub its branches point at (hepatic veins radiate from their
  // confluence, portal branches from the hilum), by its branches' cross-section; the two
  // trunks are fixed.
  const VesselGraph::Branch& pb = g.branches[static_cast<size_t>(portal)];
  const Eigen::Vector3d hub_p = 0.5 * (g.nodes[static_cast<size_t>(pb.a)].position_mm +
                                       g.nodes[static_cast<size_t>(pb.b)].position_mm);
  const Eigen::Vector3d hub_h = g.nodes[static_cast<size_t>(hepatic)].position_mm;
  std::vector<double> lean(n_nodes, 0.0), weight(n_nodes, 0.0);
  for (const auto& b : g.branches) {
    const Eigen::Vector3d pa = g.nodes[static_cast<size_t>(b.a)].position_mm;
    const Eigen::Vector3d pbb = g.nodes[static_cast<size_t>(b.b)].position_mm;
    const Eigen::Vector3d chord = pbb - pa, mid = 0.5 * (pa + pbb);
    if (chord.norm() < 1e-9) continue;
    const auto radial = [&](const Eigen::Vector3d& hub) {
      const Eigen::Vector3d out = mid - hub;
      return out.norm() < 1e-9 ? 1.0 : std::abs(chord.normalized().dot(out.normalized()));
    };
    const double area = std::numbers::pi * b.radius_mm * b.radius_mm;
    const double l = radial(hub_p) - radial(hub_h);  // > 0: portal
    for (const int32_t n : {b.a, b.b}) {
      lean[static_cast<size_t>(n)] += area * l;
      weight[static_cast<size_t>(n)] += area;
    }
  }
  FlowGraph flow(n_nodes + 2);
  const auto source = static_cast<int32_t>(n_nodes), sink = static_cast<int32_t>(n_nodes + 1);
  for (const auto& b : g.branches)
    if (b.a != b.b) add_both_ways(flow, b.a, b.b, std::numbers::pi * b.radius_mm * b.radius_mm);
  for (size_t n = 0; n < n_nodes; ++n) {
    const double l = kLeaning * lean[n];
    if (l > 0.0) add_both_ways(flow, source, static_cast<int32_t>(n), l);
    if (l < 0.0) add_both_ways(flow, static_cast<int32_t>(n), sink, -l);
  }
  add_both_ways(flow, source, pb.a, 1e12);
  add_both_ways(flow, source, pb.b, 1e12);
  add_both_ways(flow, hepatic, sink, 1e12);
  boost::boykov_kolmogorov_max_flow(flow, static_cast<size_t>(source), static_cast<size_t>(sink));
  auto color = boost::get(boost::vertex_color, flow);

  // Sides: 1 portal (the source's), 2 hepatic (the rest of the trunks' pieces), 0 neither yet.
  detail::Pieces pieces(n_nodes);
  for (const auto& b : g.branches) pieces.join(b.a, b.b);
  const auto find = [&](int32_t n) { return pieces.find(n); };
  const int32_t portal_piece = find(pb.a), hepatic_piece = find(hepatic);
  std::vector<uint8_t> side(n_nodes, 0);
  for (size_t n = 0; n < n_nodes; ++n) {
    const int32_t piece = find(static_cast<int32_t>(n));
    if (color[n] == boost::black_color)
      side[n] = 1;
    else if (color[n] == boost::white_color || piece == portal_piece || piece == hepatic_piece)
      side[n] = 2;
  }
  // Stray pieces: to the tree with the node nearest their widest node.
  SeparatedTrees out;
  std::vector<int32_t> piece_widest(n_nodes, -1);
  for (size_t n = 0; n < n_nodes; ++n) {
    if (side[n] != 0) continue;
    int32_t& w = piece_widest[static_cast<size_t>(find(static_cast<int32_t>(n)))];
    if (w < 0 || widest[static_cast<size_t>(w)] < widest[n]) w = static_cast<int32_t>(n);
  }
  std::vector<uint8_t> piece_side(n_nodes, 0);
  for (size_t p = 0; p < n_nodes; ++p) {
    const int32_t w = piece_widest[p];
    if (w < 0) continue;
    double nearest[3] = {INFINITY, INFINITY, INFINITY};
    for (size_t n = 0; n < n_nodes; ++n)
      if (side[n] != 0)
        nearest[side[n]] =
            std::min(nearest[side[n]],
                     (g.nodes[n].position_mm - g.nodes[static_cast<size_t>(w)].position_mm).norm());
    piece_side[p] = nearest[1] <= nearest[2] ? 1 : 2;
  }
  for (size_t n = 0; n < n_nodes; ++n)
    if (side[n] == 0) side[n] = piece_side[static_cast<size_t>(find(static_cast<int32_t>(n)))];
  for (const auto& b : g.branches) {
    const uint8_t sa = side[static_cast<size_t>(b.a)], sb = side[static_cast<size_t>(b.b)];
    if (sa != sb) {
      ++out.cut_branches;
      out.cut_area_mm2 += std::numbers::pi * b.radius_mm * b.radius_mm;
    } else if (piece_widest[static_cast<size_t>(find(b.a))] >= 0) {
      out.assigned_by_distance_mm += b.length_mm;
    }
  }
  out.portal = subgraph(g, side, 1);
  out.hepatic = subgraph(g, side, 2);
  return out;
}

}  // namespace lamina::geometry
