#include "lamina/io/scene.h"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/world_scene.h"
#include "lamina/model/compute_rings.h"
#include "support/sphere_model.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina::io {
namespace {

using lamina::test::TempDir;
namespace fs = std::filesystem;

// Captures what the library logs while it lives (warnings about unknown keys go there).
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ostream_sink_mt>(text_)) {
    log::logger().sinks().push_back(sink_);
  }
  ~LogCapture() {
    auto& sinks = log::logger().sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
  }
  std::string text() const { return text_.str(); }

 private:
  std::ostringstream text_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_;
};

// The message of the Error that parsing `text` throws, or "" if it does not throw. Every scene
// error must be kInvalidInput.
std::string parse_error(const std::string& text) {
  try {
    parse_scene(text, "scene.json");
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << e.what();
    return e.what();
  }
  return "";
}

// A one-layer octahedron of radius 2 mm (nodes 0..5: +x, -x, +y, -y, +z, -z) with its 12 edges
// as springs and rings up to locality 2.
Model octahedron() {
  Model m;
  m.X.resize(6, 3);
  m.X << 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2;
  m.layers.resize(1);
  m.layers[0].first_node = 0;
  m.layers[0].node_count = 6;
  m.layers[0].F.resize(8, 3);
  m.layers[0].F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m.layer_of.assign(6, 0);
  m.mass_kg.assign(6, 1.0);
  m.fixed.assign(6, 0);
  for (int32_t i = 0; i < 6; ++i)
    for (int32_t j = i + 1; j < 6; ++j) {
      if (j == i + 1 && i % 2 == 0) continue;  // opposite corners are not joined
      m.springs.i.push_back(i);
      m.springs.j.push_back(j);
      m.springs.rest_length_mm.push_back((m.X.row(i) - m.X.row(j)).norm());
      m.springs.stiffness_n_per_m.push_back(3.0);
      m.springs.kind.push_back(SpringKind::kIntraLayer);
    }
  m.rings = model::compute_rings(m, 2);
  return m;
}

TEST(ParseScene, EmptySceneIsThePhysicalLiver) {
  const Scene s = parse_scene("{}", "scene.json");
  EXPECT_EQ(s.source, "scene.json");
  EXPECT_EQ(s.input, kScenePhantom);
  EXPECT_TRUE(s.model_path.empty());
  EXPECT_EQ(s.build.structure, model::Structure::kTetrahedra);
  EXPECT_EQ(s.build.layers, 2);
  EXPECT_EQ(s.build.skin_vertices, 1284);
  EXPECT_EQ(s.build.locality, 4);
  EXPECT_TRUE(s.elastic);  // E and nu carry the stiffness
  EXPECT_DOUBLE_EQ(s.elastic_material.young_modulus_kpa, 6.0);
  EXPECT_DOUBLE_EQ(s.elastic_material.poisson_ratio, 0.45);
  EXPECT_EQ(s.tet_elasticity, model::TetElasticity::kCoupled);
  EXPECT_EQ(s.tet_model, sim::TetModel::kSprings);
  EXPECT_DOUBLE_EQ(s.material.stiffness_n_per_m, 0.0);  // no raw K
  EXPECT_DOUBLE_EQ(s.material.damping_kg_per_s, 0.0);   // damping from a ratio
  EXPECT_DOUBLE_EQ(s.material.node_mass_kg, 0.0);       // lumped masses
  EXPECT_DOUBLE_EQ(s.material.anchor_stiffness_n_per_m, 0.0);
  EXPECT_EQ(s.material.gravity_mm_per_s2, Eigen::Vector3d::Zero());
  EXPECT_FALSE(s.density_given);
  EXPECT_EQ(s.solver.integrator, sim::Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(s.solver.dt_s, 0.001);  // real time at a haptic loop's 1 kHz
  EXPECT_DOUBLE_EQ(s.solver.rest_speed_mm_per_s, 0.1);
  EXPECT_DOUBLE_EQ(s.solver.cg_tolerance, 1e-3);
  EXPECT_EQ(s.solver.max_steps, 100000);
  EXPECT_EQ(s.solver.mode, sim::Mode::kGlobal);
  // The physical tissue conserves a tool's force: no routed copies.
  EXPECT_EQ(s.routing.routing, interact::Routing::kNone);
  EXPECT_EQ(s.routing.touch, interact::Touch::kDisplaySkin);  // tools touch what is drawn
  EXPECT_EQ(s.routing.locality, 4);                           // N
  EXPECT_EQ(s.routing.penetration_depth, 4);                  // P
  EXPECT_DOUBLE_EQ(s.routing.ring_attenuation, 0.5);
  EXPECT_DOUBLE_EQ(s.routing.crossing_attenuation, 0.95);
  EXPECT_DOUBLE_EQ(s.routing.contact_threshold_mm, 10.0);
  EXPECT_TRUE(s.tools.empty());
  EXPECT_TRUE(s.default_tool);
  EXPECT_TRUE(s.fixed.empty());
  EXPECT_TRUE(s.support.empty());
  EXPECT_TRUE(s.default_fixed);
  EXPECT_DOUBLE_EQ(s.output.frame_interval_s, 0.05);
  EXPECT_FALSE(s.output.all_layers);
  EXPECT_FALSE(s.output.obj);
  EXPECT_TRUE(s.output.metrics_every_step);
  EXPECT_TRUE(s.output.embedded);
}

TEST(ParseScene, ReadsEveryKey) {
  LogCapture log;
  const Scene s = parse_scene(R"({
    // comments are allowed
    "model": {"input": "liver.nii.gz",
              "build": {"layers": 3, "skin_vertices": 2000, "layer_depth_mm": 7.5, "label": 5,
                        "locality": 6, "links": 2}},
    "material": {"stiffness_n_per_m": 6, "damping_kg_per_s": 5, "node_mass_kg": 0,
                 "anchor_stiffness_n_per_m": 0.25, "gravity_mm_per_s2": [0, 9810, 0],
                 "density_g_per_cm3": 1.1},
    "solver": {"integrator": "implicit_euler", "dt_s": 0.1, "threshold_mm": 1e-4,
               "max_steps": 1e5, "mode": "local", "routing": "paper", "locality": 3,
               "penetration_depth": 2,
               "ring_attenuation": 0.25, "crossing_attenuation": 0.9,
               "contact_threshold_mm": 4, "cg_max_iterations": 50, "cg_tolerance": 1e-8,
               "touch": "skin", "ring_spacing_mm": 2.5},
    "tools": [{"vertex": 7, "force_n": [0, 0.05, 0], "start_s": 0.5, "end_s": 1.5},
              {"point": [1, -2, 3.5], "force_n": [-0.001, 0, 0.002], "radius_mm": 2.5},
              {"vertex": 0, "force_n": [0, 0, 1], "end_s": null}],
    "boundary": {"fixed": [{"plane": {"point": [0, 80, 0], "normal": [0, 2, 0],
                                      "distance_mm": 12}},
                           {"nodes": [3, 1, 4]},
                           {"plane": {"point": [1, 2, 3], "normal": [1, 0, 0]},
                            "nodes": [9]}]},
    "output": {"frame_interval_s": 0.2, "all_layers": true, "obj": true,
               "metrics_every_step": false, "embedded": false}
  })",
                              "scene.json");
  EXPECT_EQ(log.text(), "");  // every key is known
  EXPECT_EQ(s.input, "liver.nii.gz");
  EXPECT_EQ(s.build.layers, 3);
  EXPECT_EQ(s.build.skin_vertices, 2000);
  EXPECT_DOUBLE_EQ(s.build.layer_depth_mm, 7.5);
  EXPECT_EQ(s.build.label, 5);
  EXPECT_EQ(s.build.locality, 6);
  EXPECT_EQ(s.build.inter_layer_links, 2);
  EXPECT_DOUBLE_EQ(s.material.stiffness_n_per_m, 6.0);
  EXPECT_DOUBLE_EQ(s.material.damping_kg_per_s, 5.0);
  EXPECT_DOUBLE_EQ(s.material.node_mass_kg, 0.0);
  EXPECT_DOUBLE_EQ(s.material.anchor_stiffness_n_per_m, 0.25);
  EXPECT_EQ(s.material.gravity_mm_per_s2, Eigen::Vector3d(0, 9810, 0));
  EXPECT_TRUE(s.density_given);
  EXPECT_DOUBLE_EQ(s.build.density_kg_per_mm3, 1.1e-6);  // g/cm^3 -> kg/mm^3
  EXPECT_EQ(s.solver.integrator, sim::Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(s.solver.dt_s, 0.1);
  EXPECT_DOUBLE_EQ(s.solver.rest_speed_mm_per_s, 1e-3);  // threshold_mm 1e-4 at dt 0.1 s
  EXPECT_EQ(s.solver.max_steps, 100000);
  EXPECT_EQ(s.solver.mode, sim::Mode::kLocal);
  EXPECT_EQ(s.solver.cg_max_iterations, 50);
  EXPECT_DOUBLE_EQ(s.solver.cg_tolerance, 1e-8);
  EXPECT_EQ(s.routing.routing, interact::Routing::kPaper);
  EXPECT_EQ(s.routing.locality, 3);
  EXPECT_EQ(s.routing.penetration_depth, 2);
  EXPECT_DOUBLE_EQ(s.routing.ring_attenuation, 0.25);
  EXPECT_DOUBLE_EQ(s.routing.crossing_attenuation, 0.9);
  EXPECT_DOUBLE_EQ(s.routing.contact_threshold_mm, 4.0);
  EXPECT_EQ(s.routing.touch, interact::Touch::kSkin);
  EXPECT_DOUBLE_EQ(s.routing.ring_spacing_mm, 2.5);

  ASSERT_EQ(s.tools.size(), 3u);
  EXPECT_FALSE(s.default_tool);
  EXPECT_FALSE(s.tools[0].by_point);
  EXPECT_EQ(s.tools[0].vertex, 7);
  EXPECT_DOUBLE_EQ(s.tools[0].start_s, 0.5);
  EXPECT_DOUBLE_EQ(s.tools[0].end_s, 1.5);
  EXPECT_TRUE(s.tools[1].by_point);
  EXPECT_EQ(s.tools[1].point_mm, Eigen::Vector3d(1, -2, 3.5));
  EXPECT_DOUBLE_EQ(s.tools[1].start_s, 0.0);
  EXPECT_TRUE(std::isinf(s.tools[1].end_s));  // never lets go
  EXPECT_DOUBLE_EQ(s.tools[0].radius_mm, interact::kDefaultPatchRadiusMm);
  EXPECT_DOUBLE_EQ(s.tools[1].radius_mm, 2.5);
  EXPECT_FALSE(s.tools[0].grasp);
  // A grasper: no force, a pull.
  const Scene g = parse_scene(
      R"({"tools": [{"point": [1, 2, 3], "grasp": {"pull_mm": [30, 0, 0], "pull_s": 2}}]})",
      "scene.json");
  ASSERT_EQ(g.tools.size(), 1u);
  EXPECT_TRUE(g.tools[0].grasp);
  EXPECT_EQ(g.tools[0].pull_mm, Eigen::Vector3d(30, 0, 0));
  EXPECT_DOUBLE_EQ(g.tools[0].pull_s, 2.0);
  EXPECT_EQ(g.tools[0].force_mn, Eigen::Vector3d::Zero());
  EXPECT_TRUE(std::isinf(s.tools[2].end_s));

  ASSERT_EQ(s.fixed.size(), 3u);
  EXPECT_FALSE(s.default_fixed);
  EXPECT_TRUE(s.fixed[0].has_plane);
  EXPECT_EQ(s.fixed[0].plane_point_mm, Eigen::Vector3d(0, 80, 0));
  EXPECT_EQ(s.fixed[0].plane_normal, Eigen::Vector3d(0, 2, 0));
  EXPECT_DOUBLE_EQ(s.fixed[0].distance_mm, 12.0);
  EXPECT_FALSE(s.fixed[1].has_plane);
  EXPECT_EQ(s.fixed[1].nodes, (std::vector<int32_t>{3, 1, 4}));
  EXPECT_TRUE(s.fixed[2].has_plane);
  EXPECT_DOUBLE_EQ(s.fixed[2].distance_mm, 10.0);  // the default slab
  EXPECT_EQ(s.fixed[2].nodes, (std::vector<int32_t>{9}));

  EXPECT_DOUBLE_EQ(s.output.frame_interval_s, 0.2);
  EXPECT_TRUE(s.output.all_layers);
  EXPECT_TRUE(s.output.obj);
  EXPECT_FALSE(s.output.metrics_every_step);
  EXPECT_FALSE(s.output.embedded);
}

TEST(ParseScene, TheBuildNamesTheAnatomyToEmbed) {
  const Scene s = parse_scene(R"({"model": {"build": {"labels": [1, 2, 3],
      "display_triangles": 0, "structure_triangles": 500,
      "embed": [{"label": 2, "name": "vessels"}, {"label": 3}]}}})",
                              "scene.json");
  EXPECT_EQ(s.build.labels, (std::vector<int32_t>{1, 2, 3}));
  EXPECT_EQ(s.build.display_triangles, 0);
  EXPECT_EQ(s.build.structure_triangles, 500);
  ASSERT_EQ(s.build.embed.size(), 2u);
  EXPECT_EQ(s.build.embed[0].name, "vessels");
  EXPECT_EQ(s.build.embed[0].label, 2);
  EXPECT_EQ(s.build.embed[1].name, "");
  EXPECT_EQ(s.build.embed[1].label, 3);
  EXPECT_EQ(parse_scene("{}", "scene.json").build.display_triangles, 100000);
  EXPECT_NE(parse_error(R"({"model": {"build": {"embed": [{"name": "x"}]}}})")
                .find("model.build.embed[0]: needs \"label\""),
            std::string::npos);
  EXPECT_NE(parse_error(R"({"model": {"build": {"embed": [{"label": 0}]}}})")
                .find("model.build.embed[0].label"),
            std::string::npos);
  EXPECT_NE(parse_error(R"({"model": {"build": {"labels": []}}})").find("model.build.labels"),
            std::string::npos);
  EXPECT_NE(
      parse_error(R"({"model": {"build": {"embed": {"label": 2}}}})").find("model.build.embed"),
      std::string::npos);
}

TEST(ParseScene, ToolForcesAreNewtonsInTheFileAndMilliNewtonsInside) {
  const Scene s =
      parse_scene(R"({"tools": [{"vertex": 0, "force_n": [0.05, -1, 2e-3]}]})", "scene.json");
  ASSERT_EQ(s.tools.size(), 1u);
  EXPECT_DOUBLE_EQ(s.tools[0].force_mn.x(), 50.0);
  EXPECT_DOUBLE_EQ(s.tools[0].force_mn.y(), -1000.0);
  EXPECT_DOUBLE_EQ(s.tools[0].force_mn.z(), 2.0);
}

TEST(ParseScene, ADragTimesTheGainIsTheForce) {
  const Scene s = parse_scene(
      R"({"tools": [{"vertex": 0, "drag_mm": [0, 10, 0], "gain_n_per_mm": 0.02},
                    {"vertex": 1, "drag_mm": [0, 0, -4]}]})",
      "scene.json");
  ASSERT_EQ(s.tools.size(), 2u);
  EXPECT_TRUE(s.tools[0].force_mn.isApprox(Eigen::Vector3d(0, 200, 0)));   // 0.02 N/mm x 10 mm
  EXPECT_TRUE(s.tools[1].force_mn.isApprox(Eigen::Vector3d(0, 0, -200)));  // default 0.05 N/mm
}

TEST(ParseScene, ASavedModelReplacesTheInputAndRingsFollowTheRouting) {
  const Scene s = parse_scene(
      R"({"model": {"model": "liver.vtu"}, "solver": {"locality": 6}, "tools": []})", "s.json");
  EXPECT_EQ(s.model_path, "liver.vtu");
  EXPECT_TRUE(s.input.empty());
  EXPECT_EQ(s.build.locality, 6);  // rings must reach as far as the force is spread
  EXPECT_TRUE(s.tools.empty());
  EXPECT_FALSE(s.default_tool);  // an explicit empty list means no tool, not the default poke
}

TEST(ParseScene, ErrorsNameTheFileAndTheKeyPath) {
  struct Case {
    const char* scene;
    const char* message;  // the whole message after "scene.json: ", or its start
  };
  const Case cases[] = {
      {R"({"solver": {"dt_s": -1}})", "solver.dt_s: must be > 0, got -1"},
      {R"({"solver": {"dt_s": 0}})", "solver.dt_s: must be > 0, got 0"},
      {R"({"solver": {"dt_s": "0.01"}})", "solver.dt_s: expected a number, got string \"0.01\""},
      {R"({"tools": [{"vertex": 0, "force_n": [0, 1, 0]}, {"vertex": 1, "force_n": [1, 2]}]})",
       "tools[1].force_n: expected an array of 3 numbers, got array [1,2]"},
      {R"({"tools": [{"vertex": 0, "point": [0, 0, 0], "force_n": [0, 1, 0]}]})",
       "tools[0]: give either \"point\" or \"vertex\", not both"},
      {R"({"tools": [{"force_n": [0, 1, 0]}]})", "tools[0]: needs \"point\""},
      {R"({"tools": [{"vertex": 0}]})", "tools[0]: needs \"force_n\""},
      {R"({"tools": [{"vertex": 0, "force_n": [0, 1, 0], "drag_mm": [0, 1, 0]}]})",
       "tools[0]: give either \"force_n\" or \"drag_mm\", not both"},
      {R"({"tools": [{"vertex": 0, "drag_mm": [0, 1, 0], "gain_n_per_mm": 0}]})",
       "tools[0].gain_n_per_mm: must be > 0 N/mm, got 0"},
      {R"({"tools": [{"vertex": -3, "force_n": [0, 1, 0]}]})",
       "tools[0].vertex: must be >= 0, got -3"},
      {R"({"tools": [{"vertex": 1.5, "force_n": [0, 1, 0]}]})",
       "tools[0].vertex: expected an integer, got 1.5"},
      {R"({"tools": [{"vertex": 1, "force_n": [0, 1, 0], "radius_mm": -2}]})",
       "tools[0].radius_mm: must be >= 0 mm"},
      {R"({"solver": {"routing": "copies"}})", "solver.routing: "},
      {R"({"solver": {"touch": "vessels"}})", "solver.touch: "},
      {R"({"tools": [{"vertex": 1, "force_n": [0, 1, 0], "grasp": {"pull_mm": [0, 0, 9]}}]})",
       "tools[0].force_n: a grasper pulls by grasp.pull_mm; it takes no force"},
      {R"({"tools": [{"vertex": 1, "grasp": {"pull_s": 0}}]})",
       "tools[0].grasp.pull_s: must be > 0 s"},
      {R"({"tools": [{"vertex": 1, "grasp": {}, "radius_mm": 0}]})",
       "tools[0].radius_mm: must be > 0 mm (skin within it is grasped)"},
      {R"({"tools": [{"vertex": 0, "force_n": [0, 1, 0], "start_s": 2, "end_s": 1}]})",
       "tools[0].end_s: must be after start_s (2), got 1"},
      {R"({"tools": {"vertex": 0}})", "tools: expected an array of tools"},
      {R"({"material": {"stiffness_n_per_m": -3}})",
       "material.stiffness_n_per_m: must be >= 0 (0 keeps the model's), got -3"},
      {R"({"material": {"damping_kg_per_s": -0.5}})",
       "material.damping_kg_per_s: must be >= 0, got -0.5"},
      {R"({"material": {"gravity_mm_per_s2": [0, "down", 0]}})",
       "material.gravity_mm_per_s2: expected an array of 3 numbers"},
      {R"({"material": []})", "material: expected an object {...}, got array []"},
      {R"({"material": {"young_modulus_kpa": 0}})",
       "material.young_modulus_kpa: must be > 0 (healthy liver: about 6 kPa), got 0"},
      {R"({"material": {"young_modulus_kpa": 6, "model": "mooney"}})",
       "material.model: expected \"springs\" or \"neo_hookean\", got \"mooney\""},
      {R"({"material": {"stiffness_n_per_m": 3, "model": "neo_hookean"}})",
       "material.model: needs young_modulus_kpa beside it"},
      {R"({"material": {"young_modulus_kpa": 6, "poisson_ratio": 0.5}})",
       "material.poisson_ratio: must be in [0, 0.5)"},
      {R"({"material": {"stiffness_n_per_m": 3, "poisson_ratio": 0.45}})",
       "material.poisson_ratio: needs young_modulus_kpa beside it"},
      {R"({"material": {"young_modulus_kpa": 6, "stiffness_n_per_m": 3}})",
       "material.stiffness_n_per_m: cannot be given with young_modulus_kpa"},
      {R"({"material": {"damping_ratio": 1, "damping_kg_per_s": 3}})",
       "material.damping_ratio: cannot be given with damping_kg_per_s"},
      {R"({"material": {"volume_stiffness_kpa": -1}})",
       "material.volume_stiffness_kpa: must be >= 0 (0 = no volume term), got -1"},
      {R"({"material": {"density": 1, "density_g_per_cm3": 1}})",
       "material.density: give density_g_per_cm3 or density"},
      {R"({"solver": {"locality": 0}})", "solver.locality: must be between 1 and 64, got 0"},
      {R"({"solver": {"penetration_depth": 0}})", "solver.penetration_depth: must be between 1"},
      {R"({"solver": {"integrator": "rk4"}})",
       "solver.integrator: expected \"semi_implicit_euler\", \"implicit_euler\" or \"projective\", "
       "got \"rk4\""},
      {R"({"solver": {"mode": 1}})", "solver.mode: expected a string, got 1"},
      {R"({"solver": {"max_steps": 0}})", "solver.max_steps: must be >= 1, got 0"},
      {R"({"solver": {"ring_attenuation": 1.5}})",
       "solver.ring_attenuation: must be between 0 and 1, got 1.5"},
      {R"({"solver": {"ring_spacing_mm": -1}})",
       "solver.ring_spacing_mm: must be >= 0 mm (0: rings in mesh edges), got -1"},
      {R"({"solver": {"ring_spacing_mm": "wide"}})",
       "solver.ring_spacing_mm: expected a number of mm or \"paper\", got \"wide\""},
      {R"({"solver": {"threshold_mm": 1e999}})", "invalid JSON"},  // overflows to infinity
      {R"({"model": {"input": "a.nii", "model": "b.vtu"}})",
       "model: give either \"input\" (a mask to build from) or \"model\""},
      {R"({"model": {"build": {"layers": 17}}})",
       "model.build.layers: must be between 1 and 16, got 17"},
      {R"({"model": {"input": ""}})", "model.input: must not be empty"},
      {R"({"boundary": {"fixed": [{"plane": {"point": [0, 0, 0], "normal": [0, 0, 0]}}]}})",
       "boundary.fixed[0].plane.normal: must not be zero"},
      {R"({"boundary": {"fixed": [{"plane": {"normal": [0, 1, 0]}}]}})",
       "boundary.fixed[0].plane: needs \"point\""},
      {R"({"boundary": {"fixed": [{"nodes": [1, "two"]}]}})",
       "boundary.fixed[0].nodes[1]: expected an integer, got string \"two\""},
      {R"({"boundary": {"fixed": [{}]}})", "boundary.fixed[0]: needs \"plane\""},
      {R"({"output": {"obj": "yes"}})", "output.obj: expected true or false, got string \"yes\""},
      {R"({"output": {"frame_interval_s": -0.1}})", "output.frame_interval_s: must be >= 0"},
      {R"([1, 2])", "expected a JSON object {...} at the top, got array [1,2]"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.scene);
    const std::string message = parse_error(c.scene);
    EXPECT_EQ(message.rfind(std::string("scene.json: ") + c.message, 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "one line";
  }
}

TEST(ParseScene, ThePapersConstantsBringThePapersSetup) {
  // Raw spring constants are the paper's model: its structure, solver and material, one key away.
  const Scene s = parse_scene(
      R"({"material": {"stiffness_n_per_m": 3, "damping_kg_per_s": 3, "node_mass_kg": 1}})",
      "scene.json");
  EXPECT_FALSE(s.elastic);
  EXPECT_EQ(s.build.structure, model::Structure::kLinks);
  EXPECT_DOUBLE_EQ(s.material.stiffness_n_per_m, 3.0);
  EXPECT_DOUBLE_EQ(s.material.damping_kg_per_s, 3.0);
  EXPECT_DOUBLE_EQ(s.material.node_mass_kg, 1.0);
  EXPECT_EQ(s.solver.integrator, sim::Integrator::kSemiImplicitEuler);
  EXPECT_DOUBLE_EQ(s.solver.dt_s, 0.01);
  EXPECT_EQ(s.routing.routing, interact::Routing::kPaper);
  // The paper's constants without its routing, when the file says so.
  EXPECT_EQ(parse_scene(R"({"material": {"stiffness_n_per_m": 3},
                            "solver": {"routing": "none"}})",
                        "scene.json")
                .routing.routing,
            interact::Routing::kNone);
  // An explicit structure stays; paper_scene() is the same setup.
  const Scene t = parse_scene(R"({"model": {"build": {"structure": "tets"}},
                                  "material": {"stiffness_n_per_m": 3}})",
                              "scene.json");
  EXPECT_EQ(t.build.structure, model::Structure::kTetrahedra);
  const Scene p = paper_scene();
  EXPECT_FALSE(p.elastic);
  EXPECT_EQ(p.build.structure, model::Structure::kLinks);
  EXPECT_DOUBLE_EQ(p.material.stiffness_n_per_m, 3.0);
  EXPECT_DOUBLE_EQ(p.solver.dt_s, 0.01);
  EXPECT_DOUBLE_EQ(p.solver.rest_speed_mm_per_s, 0.1);  // the paper's 1e-3 mm per 0.01 s step
  EXPECT_EQ(p.routing.routing, interact::Routing::kPaper);
}

TEST(ParseScene, AnElasticMaterialReplacesThePapersConstants) {
  const Scene s = parse_scene(R"({"material": {"young_modulus_kpa": 4.5, "poisson_ratio": 0.49,
                                               "density": 1.05}})",
                              "scene.json");
  EXPECT_TRUE(s.elastic);
  EXPECT_DOUBLE_EQ(s.elastic_material.young_modulus_kpa, 4.5);
  EXPECT_DOUBLE_EQ(s.elastic_material.poisson_ratio, 0.49);
  EXPECT_DOUBLE_EQ(s.build.density_kg_per_mm3, 1.05e-6);
  EXPECT_EQ(s.material.stiffness_n_per_m, 0.0);  // the model's (identified) constants
  EXPECT_EQ(s.material.node_mass_kg, 0.0);       // lumped masses
  EXPECT_EQ(s.material.damping_kg_per_s, 0.0);   // damping comes from a ratio instead
  EXPECT_FALSE(s.volume_stiffness_given);
  EXPECT_FALSE(s.integrator_given);
  const Scene p = parse_scene(R"({"material": {"stiffness_n_per_m": 3, "volume_stiffness_kpa": 2,
                                               "mass_damping_per_s": 4},
                                  "solver": {"integrator": "projective"}})",
                              "scene.json");
  EXPECT_FALSE(p.elastic);
  EXPECT_DOUBLE_EQ(p.material.volume_stiffness_kpa, 2.0);
  EXPECT_DOUBLE_EQ(p.material.mass_damping_per_s, 4.0);
  EXPECT_TRUE(p.volume_stiffness_given && p.damping_given && p.integrator_given);
}

TEST(ResolveMaterial, LinksIdentifiesSpringsTurnsOnTheVolumeTermAndDampsFromTheRatio) {
  Model m = test::sphere_links_model();
  Scene s = parse_scene(R"({"material": {"young_modulus_kpa": 6, "poisson_ratio": 0.45},
                           "solver": {"dt_s": 0.01}})",
                        "scene.json");
  const SceneSetup setup = prepare_scene(s, m);
  const MaterialReport& r = setup.material;
  EXPECT_TRUE(r.elastic);
  EXPECT_FALSE(r.tets);
  EXPECT_GT(r.supported_nodes, 0);  // the posterior surface, held by the body around it
  EXPECT_NE(m.springs.stiffness_n_per_m, test::sphere_links_model().springs.stiffness_n_per_m);
  EXPECT_NEAR(s.material.volume_stiffness_kpa,
              r.identification.lame_lambda_kpa - r.identification.shear_modulus_kpa, 1e-12);
  EXPECT_EQ(s.solver.integrator, sim::Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(r.damping_ratio, 1.0);
  EXPECT_GT(r.lowest_frequency_hz, 0.0);
  EXPECT_NEAR(s.material.mass_damping_per_s, 2.0 * 2.0 * 3.14159265358979 * r.lowest_frequency_hz,
              1e-9 * s.material.mass_damping_per_s);
  // Physical tissue against its node masses: the explicit limit is far below the paper's dt.
  EXPECT_LT(r.explicit_dt_limit_s, 0.01);
}

TEST(ResolveMaterial, TetrahedraCarryEAndNuThemselves) {
  Model m = test::sphere_model();
  Scene s = parse_scene("{}", "scene.json");
  const SceneSetup setup = prepare_scene(s, m);
  EXPECT_TRUE(setup.material.tets);
  EXPECT_DOUBLE_EQ(s.material.young_modulus_kpa, 6.0);
  EXPECT_DOUBLE_EQ(s.material.poisson_ratio, 0.45);
  EXPECT_DOUBLE_EQ(s.material.volume_stiffness_kpa, 0.0);  // the tetrahedra keep the volume
  EXPECT_NEAR(setup.material.tet_volume_modulus_kpa,
              model::kVolumeShare * 6.0 * 0.45 / (1.45 * 0.1), 1e-9);  // its share of lambda
  EXPECT_EQ(m.springs.stiffness_n_per_m, test::sphere_model().springs.stiffness_n_per_m);
  EXPECT_GT(s.material.mass_damping_per_s, 0.0);
  const sim::Simulation sim = make_scene_simulation(s, m, setup);
  EXPECT_GT(sim.tet_identification().spring_n_per_m.size(), 0u);
  EXPECT_EQ(s.material.tet_model, sim::TetModel::kSprings);

  // Stable Neo-Hookean in the same tetrahedra: J's modulus is lambda + mu.
  Model neo_model = test::sphere_model();
  Scene neo = parse_scene(R"({"material": {"young_modulus_kpa": 6, "model": "neo_hookean"}})",
                          "scene.json");
  EXPECT_EQ(neo.tet_model, sim::TetModel::kNeoHookean);
  const SceneSetup neo_setup = prepare_scene(neo, neo_model);
  EXPECT_EQ(neo.material.tet_model, sim::TetModel::kNeoHookean);
  EXPECT_EQ(neo_setup.material.tet_model, sim::TetModel::kNeoHookean);
  const double mu = 6.0 / 2.9, lambda = 6.0 * 0.45 / (1.45 * 0.1);
  EXPECT_NEAR(neo_setup.material.tet_volume_modulus_kpa, lambda + mu, 1e-9);
  EXPECT_NE(run_summary_json({.material = neo_setup.material}).find("\"model\": \"neo_hookean\""),
            std::string::npos);
}

// The viewer's Model panel rebuilds the scene at another resolution. The rebuilt model is
// prepared as any scene is: its damping follows its own slowest vibration (a rebuild that kept
// the first model's material once left a rebuilt physical liver with the old damping).
TEST(RebuildReadyScene, ResolvesTheMaterialForTheNewModel) {
  const Scene parsed =
      parse_scene(R"({"model": {"build": {"skin_vertices": 300, "layers": 2}}})", "scene.json");
  const ReadyScene first = make_ready_scene(parsed);
  const ReadyScene rebuilt = rebuild_ready_scene(first.parsed, 3, 600);
  EXPECT_EQ(rebuilt.model->layer_count(), 3);
  EXPECT_GT(rebuilt.model->layers[0].node_count, first.model->layers[0].node_count);
  // The same preparation from scratch on a scene asking for that model gives the same material.
  Scene direct = parsed;
  direct.build.layers = 3;
  direct.build.skin_vertices = 600;
  const ReadyScene fresh = make_ready_scene(direct);
  EXPECT_DOUBLE_EQ(rebuilt.scene.material.mass_damping_per_s,
                   fresh.scene.material.mass_damping_per_s);
  EXPECT_DOUBLE_EQ(rebuilt.setup.material.lowest_frequency_hz,
                   fresh.setup.material.lowest_frequency_hz);
  // ... and not the first model's (close, the same organ, but another mesh: 4e-4 apart here).
  EXPECT_NE(rebuilt.scene.material.mass_damping_per_s, first.scene.material.mass_damping_per_s);
  EXPECT_EQ(rebuilt.setup.fixed, fresh.setup.fixed);
  EXPECT_EQ(rebuilt.setup.support.nodes, fresh.setup.support.nodes);
  // A later rebuild starts from the scene as given, not from the resolved one.
  EXPECT_TRUE(rebuilt.parsed.default_tool == parsed.default_tool);
  const sim::Simulation s = make_scene_simulation(rebuilt);
  EXPECT_EQ(s.material().mass_damping_per_s, rebuilt.scene.material.mass_damping_per_s);
}

TEST(ResolveMaterial, ADampingRatioOnAModelHeldNowhereIsRefused) {
  Model free = test::sphere_model();
  Scene f = parse_scene(R"({"material": {"damping_ratio": 0.5}, "boundary": {"fixed": []}})",
                        "free.json");
  try {
    prepare_scene(f, free);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("free.json: material.damping_ratio: ", 0), 0u)
        << e.what();
  }
}

TEST(ParseScene, MalformedJsonGivesTheParsersLineAndColumn) {
  const std::string message = parse_error("{\n  \"solver\": {\"dt_s\": 0.01,}\n}");
  EXPECT_NE(message.find("scene.json: invalid JSON: parse error at line 2, column"),
            std::string::npos)
      << message;
}

TEST(ParseScene, UnknownKeysAreWarningsNamingTheKeyPath) {
  LogCapture log;
  Scene s;
  ASSERT_NO_THROW(s = parse_scene(R"({"solver": {"dtt_s": 0.5, "dt_s": 0.02},
                                      "tools": [{"vertex": 0, "force_n": [0, 1, 0], "colour": 1}],
                                      "notes": "a comment field"})",
                                  "scene.json"));
  EXPECT_DOUBLE_EQ(s.solver.dt_s, 0.02);
  const std::string text = log.text();
  EXPECT_NE(text.find("scene.json: solver.dtt_s: unknown key, ignored"), std::string::npos) << text;
  EXPECT_NE(text.find("scene.json: tools[0].colour: unknown key"), std::string::npos) << text;
  EXPECT_NE(text.find("scene.json: notes: unknown key"), std::string::npos) << text;
}

TEST(LoadScene, RelativePathsAreRelativeToTheScenesFolder) {
  TempDir dir;
  fs::create_directories(dir.path / "scenes");
  const std::string path = (dir.path / "scenes" / "s.json").string();
  std::ofstream(path) << R"({"model": {"input": "../data/liver.nii.gz"}})";
  EXPECT_EQ(load_scene(path).input, (dir.path / "data" / "liver.nii.gz").string());
  std::ofstream(path) << R"({"model": {"model": "/abs/liver.vtu"}})";
  EXPECT_EQ(load_scene(path).model_path, "/abs/liver.vtu");
  std::ofstream(path) << R"({"model": {"input": "phantom"}})";
  EXPECT_EQ(load_scene(path).input, kScenePhantom);
}

TEST(LoadScene, MissingFileIsAnInputErrorNamingIt) {
  TempDir dir;
  const std::string path = dir.file("nope.json");
  try {
    load_scene(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
  }
}

TEST(ParseScene, AScalpelIsAToolOfItsOwnWithEveryKeyChecked) {
  const Scene s = parse_scene(R"({"tools": [{"point": [0, 0, 0], "force_n": [0, 1, 0]},
      {"scalpel": {"path": [[0, 0, 0], [10, 0, 0], [10, 5, 0]], "direction": [0, 0, 2],
                   "depth_mm": 12, "start_s": 0.5, "end_s": 1.5}}]})",
                              "s.json");
  ASSERT_EQ(s.tools.size(), 1u);
  ASSERT_EQ(s.scalpels.size(), 1u);
  const interact::Scalpel& c = s.scalpels[0];
  ASSERT_EQ(c.path.size(), 3u);
  EXPECT_EQ(c.path[2], Eigen::Vector3d(10, 5, 0));
  EXPECT_EQ(c.depth_direction, Eigen::Vector3d(0, 0, 2));
  EXPECT_EQ(c.depth_mm, 12.0);
  EXPECT_EQ(c.start_s, 0.5);
  EXPECT_EQ(c.end_s, 1.5);
  const auto fails = [](const std::string& scalpel) {
    try {
      parse_scene(R"({"tools": [{"scalpel": )" + scalpel + "}]}", "s.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(fails(R"({"path": [[0, 0, 0]], "depth_mm": 5, "end_s": 1})"),
            "s.json: tools[0].scalpel.path: expected an array of at least two points [[x, y, z], "
            "...], got array [[0,0,0]]");
  EXPECT_EQ(fails(R"({"path": [[0, 0, 0], [0, 0, 0]], "depth_mm": 5, "end_s": 1})"),
            "s.json: tools[0].scalpel.path: has zero length: its points are one");
  EXPECT_EQ(fails(R"({"path": [[0, 0, 0], [1, 0, 0]], "depth_mm": 5})"),
            "s.json: tools[0].scalpel: needs \"end_s\" (when the blade reaches the path's end, s)");
  EXPECT_EQ(fails(R"({"path": [[0, 0, 0], [1, 0, 0]], "depth_mm": 5, "end_s": 1,
                      "start_s": 2})"),
            "s.json: tools[0].scalpel.end_s: must be after start_s (2), got 1");
  EXPECT_NE(parse_scene(R"({"tools": [{"scalpel": {"path": [[0, 0, 0], [1, 0, 0]],
                "depth_mm": 5, "end_s": 1}}]})",
                        "s.json")
                .scalpels.size(),
            0u);
  try {
    parse_scene(R"({"tools": [{"scalpel": {"path": [[0, 0, 0], [1, 0, 0]], "depth_mm": 5,
                    "end_s": 1}, "force_n": [0, 1, 0]}]})",
                "s.json");
    ADD_FAILURE() << "a scalpel with a force beside it was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tools[0]: a scalpel is its own tool"), std::string::npos)
        << e.what();
  }
}

TEST(LoadScene, EveryShippedExampleParsesWithoutWarnings) {
  const fs::path examples = test::source_path("examples");
  int count = 0;
  for (const auto& e : fs::directory_iterator(examples)) {
    if (e.path().extension() != ".json") continue;
    SCOPED_TRACE(e.path().string());
    LogCapture log;
    if (is_world_scene_file(e.path().string())) {
      // A world scene (examples/cholecystectomy.json): its bodies, each a scene.
      WorldScene w;
      ASSERT_NO_THROW(w = load_world_scene(e.path().string()));
      EXPECT_EQ(log.text(), "");
      EXPECT_GE(w.bodies.size(), 2u);
      try {
        load_scene(e.path().string());
        ADD_FAILURE() << "a world scene was read as one organ's";
      } catch (const Error& x) {
        EXPECT_NE(std::string(x.what()).find("is a world scene"), std::string::npos) << x.what();
      }
      ++count;
      continue;
    }
    Scene s;
    ASSERT_NO_THROW(s = load_scene(e.path().string()));
    EXPECT_EQ(log.text(), "");
    // a tool, listed or the default poke, or a scalpel
    EXPECT_TRUE(!s.tools.empty() || !s.scalpels.empty() || s.default_tool);
    ++count;
  }
  EXPECT_GE(count, 7);
}

TEST(ResolveSceneDefaults, ThePapersPokeAndThePosteriorSurfaceSupported) {
  const Model m = octahedron();
  Scene s;  // the default scene: the physical liver
  resolve_scene_defaults(s, m);
  EXPECT_FALSE(s.default_tool);
  EXPECT_FALSE(s.default_fixed);
  ASSERT_EQ(s.tools.size(), 1u);
  EXPECT_FALSE(s.tools[0].by_point);
  EXPECT_EQ(s.tools[0].vertex, 3);                             // (0, -2, 0): smallest y
  EXPECT_EQ(s.tools[0].force_mn, Eigen::Vector3d(0, 400, 0));  // 0.4 N posteriorly
  EXPECT_DOUBLE_EQ(s.tools[0].start_s, 0.0);
  EXPECT_DOUBLE_EQ(s.tools[0].end_s, 1.0);
  EXPECT_TRUE(s.fixed.empty());
  ASSERT_EQ(s.support.size(), 1u);
  EXPECT_EQ(s.support[0].direction, Eigen::Vector3d::UnitY());  // posterior
  const model::SurfaceSupport sup = model::surface_support(m, s.support[0]);
  EXPECT_EQ(sup.nodes, (std::vector<int32_t>{2}));  // (0, 2, 0): the one facing +y

  // The paper's constants: the posterior 10 mm held.
  Scene p = paper_scene();
  resolve_scene_defaults(p, m);
  ASSERT_EQ(p.fixed.size(), 1u);
  EXPECT_TRUE(p.support.empty());
  EXPECT_EQ(p.fixed[0].plane_point_mm.y(), 2.0);  // through the largest y
  EXPECT_EQ(p.fixed[0].plane_normal, Eigen::Vector3d::UnitY());
  EXPECT_DOUBLE_EQ(p.fixed[0].distance_mm, 10.0);

  // Explicit tools and boundary are kept as they are.
  Scene t = parse_scene(R"({"tools": [], "boundary": {}})", "s.json");
  resolve_scene_defaults(t, m);
  EXPECT_TRUE(t.tools.empty());
  EXPECT_TRUE(t.fixed.empty());
  EXPECT_TRUE(t.support.empty());

  // "paper" ring spacing: the edge of the organ's paper-size skin, once the model is known.
  Scene r =
      parse_scene(R"({"solver": {"routing": "paper", "ring_spacing_mm": "paper"}})", "s.json");
  EXPECT_EQ(r.routing.ring_spacing_mm, interact::kPaperRingSpacing);
  resolve_scene_defaults(r, m);
  EXPECT_GT(r.routing.ring_spacing_mm, 0.0);
  EXPECT_DOUBLE_EQ(r.routing.ring_spacing_mm, interact::paper_ring_spacing_mm(m));
}

TEST(ParseScene, SupportRegionsAreReadAndChecked) {
  const Scene s = parse_scene(R"({"boundary": {"support": [{"direction": [0, 0, -1],
                                  "max_angle_deg": 45, "stiffness_kpa_per_mm": 0.25}]}})",
                              "s.json");
  ASSERT_EQ(s.support.size(), 1u);
  EXPECT_EQ(s.support[0].direction, Eigen::Vector3d(0, 0, -1));
  EXPECT_DOUBLE_EQ(s.support[0].max_angle_deg, 45.0);
  EXPECT_DOUBLE_EQ(s.support[0].stiffness_kpa_per_mm, 0.25);
  EXPECT_TRUE(s.fixed.empty());
  for (const auto& [scene, message] : std::vector<std::pair<std::string, std::string>>{
           {R"({"boundary": {"support": [{"direction": [0, 0, 0]}]}})",
            "s.json: boundary.support[0].direction: must not be zero"},
           {R"({"boundary": {"support": [{"max_angle_deg": 200}]}})",
            "s.json: boundary.support[0].max_angle_deg: must be between 0 and 180 degrees"},
           {R"({"boundary": {"support": [{"stiffness_kpa_per_mm": -1}]}})",
            "s.json: boundary.support[0].stiffness_kpa_per_mm: must be >= 0 kPa/mm"},
           {R"({"boundary": {"support": {}}})", "s.json: boundary.support: expected an array"}}) {
    try {
      parse_scene(scene, "s.json");
      ADD_FAILURE() << scene;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(message, 0), 0u) << e.what();
    }
  }
}

TEST(FixedSceneNodes, UnionOfPlanesAndListsSortedAndUnique) {
  const Model m = octahedron();
  const Scene s = parse_scene(R"({"boundary": {"fixed": [
      {"plane": {"point": [0, 2, 0], "normal": [0, 1, 0], "distance_mm": 0.5}, "nodes": [5, 2]},
      {"nodes": [5, 0]}]}})",
                              "s.json");
  EXPECT_EQ(fixed_scene_nodes(s, m), (std::vector<int32_t>{0, 2, 5}));
}

TEST(CheckSceneAgainstModel, NamesTheKeyThatDoesNotFitTheModel) {
  const Model m = octahedron();
  auto message = [&](const std::string& text) -> std::string {
    const Scene s = parse_scene(text, "scene.json");
    try {
      check_scene_against_model(s, m);
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(R"({"solver": {"locality": 2},
                        "tools": [{"vertex": 5, "force_n": [0, 1, 0]},
                                  {"point": [0, 0, 2.5], "force_n": [0, 1, 0]}],
                        "boundary": {"fixed": [{"nodes": [5]}]}})"),
            "");
  EXPECT_EQ(
      message(
          R"({"tools": [{"vertex": 0, "force_n": [0, 1, 0]}, {"vertex": 6, "force_n": [0, 1, 0]}],
                        "solver": {"locality": 2}})"),
      "scene.json: tools[1].vertex: must be a skin node, 0..5, got 6");
  EXPECT_EQ(message(R"({"tools": [{"point": [0, 0, 30], "force_n": [0, 1, 0]}],
                        "solver": {"locality": 2}})")
                .rfind("scene.json: tools[0].point: [0, 0, 30] is farther than "
                       "solver.contact_threshold_mm (10 mm)",
                       0),
            0u);
  EXPECT_EQ(message(R"({"tools": [{"point": [0, 0, 0], "force_n": [0, 1, 0], "radius_mm": 0.5}],
                        "solver": {"locality": 2}})"),
            "scene.json: tools[0].point: [0, 0, 0] is inside the organ, 1.2 mm under the skin at "
            "rest: a tool starts outside the organ or on its skin");
  EXPECT_EQ(message(R"({"tools": [{"point": [0, 0, 0], "force_n": [0, 1, 0], "radius_mm": 2}],
                        "solver": {"locality": 2}})"),
            "")
      << "1.2 mm under the skin: within the tool's 2 mm radius, a press";
  EXPECT_EQ(message(R"({"tools": [{"point": [0, 0, 1.3], "force_n": [0, 1, 0], "radius_mm": 0.5}],
                        "solver": {"locality": 2}})"),
            "")
      << "0.4 mm under the skin: a point picked on it and rounded";
  EXPECT_EQ(message(R"({"tools": [{"point": [0, 0, 30], "grasp": {}}],
                        "solver": {"locality": 2}})")
                .rfind("scene.json: tools[0].point: nothing under the grasper's jaws: no skin "
                       "node within radius_mm (5 mm) of [0, 0, 30] at rest",
                       0),
            0u);
  EXPECT_EQ(message(R"({"tools": []})"),  // default locality 4 > the model's 2
            "scene.json: solver.locality: must be between 1 and the model's rings (2), got 4");
  EXPECT_EQ(message(R"({"tools": [], "solver": {"locality": 1},
                        "boundary": {"fixed": [{"nodes": [0, 6]}]}})"),
            "scene.json: boundary.fixed[0].nodes[1]: must be a node of the model, 0..5, got 6");
}

TEST(RunSummaryJson, ReportsNanDetectedFromRecoveries) {
  RunSummary r;
  r.integrator = sim::Integrator::kImplicitEuler;
  r.mode = sim::Mode::kLocal;
  std::string json = run_summary_json(r);
  EXPECT_NE(json.find("\"nan_detected\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"integrator\": \"implicit_euler\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"mode\": \"local\""), std::string::npos) << json;
  r.recoveries = 2;
  json = run_summary_json(r);
  EXPECT_NE(json.find("\"nan_detected\": true"), std::string::npos) << json;
}

}  // namespace
}  // namespace lamina::io
