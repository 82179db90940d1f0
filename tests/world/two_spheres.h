#pragma once
// Two test spheres side by side in a world (the world's tests and the world loop's): A pressed
// towards B, B's far side fixed; their ties.
#include <memory>
#include <vector>

#include "lamina/world/world.h"
#include "support/held_sphere.h"
#include "support/sphere_model.h"

namespace lamina::world::test_world {

// The test sphere scaled by `scale` about its centre (masses with its volume), moved by `offset`.
inline std::shared_ptr<Model> sphere_at(const Eigen::Vector3d& offset, double scale = 1.0) {
  Eigen::Vector3d c;
  auto m = std::make_shared<Model>(test::sphere_model(&c));
  if (scale != 1.0) {
    m->X = ((m->X.rowwise() - c.transpose()) * scale).rowwise() + c.transpose();
    for (double& k : m->mass_kg) k *= scale * scale * scale;
    for (double& l : m->springs.rest_length_mm) l *= scale;
  }
  m->X.rowwise() += offset.transpose();
  return m;
}

inline Eigen::Vector3d sphere_centre() {
  Eigen::Vector3d c;
  test::sphere_model(&c);
  return c;
}

inline sim::Simulation tissue_on(const Model& m) {
  return test::soft_tissue(m);
}

// Skin nodes whose x is beyond `x` on the side of `sign`.
inline std::vector<int32_t> cap(const Model& m, double x, double sign) {
  std::vector<int32_t> nodes;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (sign * (m.X(i, 0) - x) > 0.0) nodes.push_back(i);
  return nodes;
}

inline int32_t skin_node_with_least_x(const Model& m) {
  int32_t best = 0;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (m.X(i, 0) < m.X(best, 0)) best = i;
  return best;
}

// A slit into A from above, across y, ending inside it short of B (A spans x within 20 mm of
// the centre, B starts 0.5 mm beyond).
struct Slit {
  std::vector<Eigen::Vector3d> path;
  Eigen::Vector3d direction = -Eigen::Vector3d::UnitZ();
  double depth_mm = 50.0;
};

inline Slit slit_into_a() {
  const Eigen::Vector3d c = sphere_centre();
  const double y = c.y() + 0.37;  // off the nodes' planes
  return {{{c.x() - 25.0, y, c.z() + 25.0}, {c.x() + 10.0, y, c.z() + 25.0}}};
}

inline double rest_distance(const Body& b) {
  return (b.sim.x - b.model->X).rowwise().norm().maxCoeff();
}

// Two spheres side by side along x, 0.5 mm apart: A, elastically supported on its far cap,
// pressed towards B by `press_n` over its far half until `press_end_s`; B's far side fixed.
struct TwoSpheres {
  World world;
  BodyId a, b;
};

inline TwoSpheres two_spheres(double gap_mm, double press_n, double press_end_s,
                              double scale = 1.0) {
  TwoSpheres t;
  const Eigen::Vector3d c = sphere_centre();
  const double r = 20.0 * scale;
  auto ma = sphere_at(Eigen::Vector3d::Zero(), scale);
  auto mb = sphere_at(Eigen::Vector3d(2.0 * r + gap_mm, 0.0, 0.0), scale);
  sim::Simulation sa = tissue_on(*ma), sb = tissue_on(*mb);
  std::vector<int32_t> held;
  for (int32_t i = 0; i < ma->layers[0].node_count; ++i)
    if (ma->X(i, 0) < c.x() - 0.6 * r) held.push_back(i);
  sim::support_nodes(sa, held, std::vector<double>(held.size(), 1.0));
  sim::fix_nodes(sb, cap(*mb, c.x() + 2.0 * r + gap_mm + 0.6 * r, +1.0));
  interact::ToolDriver press{
      .tools = {{.vertex = skin_node_with_least_x(*ma),
                 .force_mn = Eigen::Vector3d(1000.0 * press_n, 0.0, 0.0),
                 .start_s = 0.0,
                 .end_s = press_end_s,
                 .radius_mm = 1.25 * r}},  // the whole far half: a press, not an indentation
      .routing = {.routing = interact::Routing::kNone, .touch = interact::Touch::kSkin}};
  t.a =
      create_body(t.world, {.name = "a", .model = ma, .simulation = std::move(sa), .tools = press});
  t.b = create_body(t.world, {.name = "b", .model = mb, .simulation = std::move(sb), .tools = {}});
  return t;
}

inline AttachmentId attach(TwoSpheres& t, double strength_kpa) {
  return create_attachment(t.world, {.body_a = t.a.index,
                                     .body_b = t.b.index,
                                     .generation_a = t.a.generation,
                                     .generation_b = t.b.generation,
                                     .reach_mm = 2.0,
                                     .stiffness_kpa_per_mm = 2.0,
                                     .strength_kpa = strength_kpa});
}

}  // namespace lamina::world::test_world
