// A World's bodies changed between steps from Python: tools and graspers on a body, a body's
// material, and the last cut taken back (docs/python.md, "Worlds").
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "bindings.h"
#include "lamina/interact/grasp.h"
#include "py_world.h"

namespace py = pybind11;

namespace lamina::python {
namespace {

void clear_tools(world::Body& b) {
  for (interact::Grasp& g : b.tools.grasps) interact::open_jaws(b.sim, g);
  b.tools.tools.clear();
  b.tools.routes.clear();
  b.tools.active.clear();
  b.tools.grasps.clear();
}

py::dict material_dict(const sim::Material& m) {
  py::dict d;
  d["young_modulus_kpa"] = m.young_modulus_kpa;
  d["poisson_ratio"] = m.poisson_ratio;
  d["mass_damping_per_s"] = m.mass_damping_per_s;
  d["damping_kg_per_s"] = m.damping_kg_per_s;
  d["volume_stiffness_kpa"] = m.volume_stiffness_kpa;
  d["stiffness_n_per_m"] = m.stiffness_n_per_m;
  return d;
}

// World.add_tool, add_grasp, clear_tools and reaction_force_mn: each body's scripted tools, on
// the world's clock, as Simulation's.
void bind_world_tools(py::class_<PyWorld>& world) {
  world
      .def(
          "add_tool",
          [](PyWorld& w, const std::string& name, std::optional<Eigen::Vector3d> point_mm,
             std::optional<int32_t> vertex, const Eigen::Vector3d& force_mn,
             std::optional<double> start_s, double end_s, double radius_mm) {
            world::Body& b = body_named(w, name);
            b.tools.tools.push_back(tool_from("add_tool", point_mm, vertex, force_mn, start_s,
                                              end_s, radius_mm, w.ready->world.time_s));
            return b.tools.tools.size() - 1;
          },
          py::arg("body"), py::kw_only(), py::arg("point_mm") = py::none(),
          py::arg("vertex") = py::none(), py::arg("force_mn"), py::arg("start_s") = py::none(),
          py::arg("end_s") = std::numeric_limits<double>::infinity(),
          py::arg("radius_mm") = interact::kDefaultPatchRadiusMm,
          "Simulation.add_tool on body `body`: a tool pushing its skin with force_mn (mN) at\n"
          "point_mm (or skin node `vertex`) from start_s (default: now, on the world's clock)\n"
          "until end_s. Returns its index among the body's tools.")
      .def(
          "add_grasp",
          [](PyWorld& w, const std::string& name, std::optional<Eigen::Vector3d> point_mm,
             std::optional<int32_t> vertex, const Eigen::Vector3d& pull_mm, double pull_s,
             std::optional<double> start_s, double end_s, double radius_mm) {
            world::Body& b = body_named(w, name);
            b.tools.tools.push_back(grasp_from("add_grasp", point_mm, vertex, pull_mm, pull_s,
                                               start_s, end_s, radius_mm, w.ready->world.time_s));
            return b.tools.tools.size() - 1;
          },
          py::arg("body"), py::kw_only(), py::arg("point_mm") = py::none(),
          py::arg("vertex") = py::none(), py::arg("pull_mm") = Eigen::Vector3d::Zero(),
          py::arg("pull_s") = 1.0, py::arg("start_s") = py::none(),
          py::arg("end_s") = std::numeric_limits<double>::infinity(), py::arg("radius_mm") = 4.0,
          "Simulation.add_grasp on body `body`: jaws holding its free skin nodes within\n"
          "radius_mm of point_mm (or skin node `vertex`), moving by pull_mm over pull_s and\n"
          "holding; the step that closes them on nothing raises lamina.Error. Returns its index.")
      .def(
          "clear_tools",
          [](PyWorld& w, std::optional<std::string> name) {
            if (name) return clear_tools(body_named(w, *name));
            for (const world::BodyId id : w.ready->ids)
              clear_tools(world::body(w.ready->world, id));
          },
          py::arg("body") = py::none(),
          "Lifts body `body`'s tools off (graspers let go); every body's without it.")
      .def(
          "reaction_force_mn",
          [](const PyWorld& w, const std::string& name) {
            const world::Body& b = body_named(w, name);
            return Eigen::Vector3d(interact::tools_reaction(b.sim, b.tools));
          },
          py::arg("body"), "The tissue's push back on body `body`'s tools in the last step, mN.");
}

// World.material, set_material and undo_cut.
void bind_world_changes(py::class_<PyWorld>& world) {
  world
      .def(
          "material",
          [](const PyWorld& w, const std::string& name) {
            return material_dict(body_named(w, name).sim.material());
          },
          py::arg("body"),
          "Body `body`'s material as it steps: young_modulus_kpa, poisson_ratio,\n"
          "mass_damping_per_s, damping_kg_per_s, volume_stiffness_kpa, stiffness_n_per_m.")
      .def(
          "set_material",
          [](PyWorld& w, const std::string& name, std::optional<double> young_modulus_kpa,
             std::optional<double> poisson_ratio, std::optional<double> mass_damping_per_s,
             std::optional<double> damping_kg_per_s, std::optional<double> volume_stiffness_kpa) {
            world::Body& b = body_named(w, name);
            sim::Material m = b.sim.material();
            if (young_modulus_kpa) m.young_modulus_kpa = *young_modulus_kpa;
            if (poisson_ratio) m.poisson_ratio = *poisson_ratio;
            if (mass_damping_per_s) m.mass_damping_per_s = *mass_damping_per_s;
            if (damping_kg_per_s) m.damping_kg_per_s = *damping_kg_per_s;
            if (volume_stiffness_kpa) m.volume_stiffness_kpa = *volume_stiffness_kpa;
            py::gil_scoped_release release;
            sim::set_parameters(b.sim, m, b.sim.options());  // checks first: nothing changes
          },
          py::arg("body"), py::kw_only(), py::arg("young_modulus_kpa") = py::none(),
          py::arg("poisson_ratio") = py::none(), py::arg("mass_damping_per_s") = py::none(),
          py::arg("damping_kg_per_s") = py::none(), py::arg("volume_stiffness_kpa") = py::none(),
          "Body `body`'s material from the next step: the keys given change, the others stay.\n"
          "A new E or nu identifies its tetrahedra's springs again (docs/physics.md); its\n"
          "shape and motion stay. Raises lamina.Error naming a bad value, nothing changed.")
      .def(
          "undo_cut",
          [](PyWorld& w) {
            if (w.cuts.undo.empty())
              throw invalid_input("undo_cut",
                                  "there is no cut to undo (none since the reset, "
                                  "or the last " +
                                      std::to_string(world::CutHistory::kDepth) + " taken back)");
            world::CutUndo u = std::move(w.cuts.undo.back());
            w.cuts.undo.pop_back();
            std::vector<std::string> bodies;
            for (const world::BodyBefore& k : u.before.bodies)
              if (world::is_valid(w.ready->world, k.id)) {
                world::Body& b = world::body(w.ready->world, k.id);
                bodies.push_back(b.name);
                retire(w, b);  // views taken before keep their buffers
              }
            int32_t joined = 0;
            {
              py::gil_scoped_release release;
              joined = world::undo_cut(w.ready->world, u);
            }
            return py::dict(py::arg("bodies") = bodies, py::arg("ties_joined") = joined);
          },
          "Takes the last cut back: every body it divided as it was just before it (its shape,\n"
          "motion and tools: one added since is lifted; its clock, material and routing stay\n"
          "those of now; a grasp on it lets go), its topology generation moving on again\n"
          "(views taken before show it cut: take them again); the ties its stroke divided\n"
          "joined again, the others as they are now. The last 8 cuts can be taken back, one\n"
          "call each. Returns {bodies: [names], ties_joined}. Raises lamina.Error when there\n"
          "is no cut to undo.");
}

}  // namespace

void bind_world_edit(py::class_<PyWorld>& world) {
  bind_world_tools(world);
  bind_world_changes(world);
}

}  // namespace lamina::python
