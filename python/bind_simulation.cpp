// Simulations: made from a model with keyword arguments (the C++ defaults and units), or from a
// scene as `lamina run` sets it up; stepped with tools and raw forces; state as numpy views.
#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <variant>

#include "bindings.h"
#include "lamina/core/error.h"
#include "lamina/interact/run_tools.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/world/cut_body.h"
#include "lamina/world/world.h"

namespace py = pybind11;

namespace lamina::python {
namespace {

// What a Python Simulation holds: a world of one body (world::one_body_world), the organ, whose
// model, simulation and tools are the body's and which world::step() steps, as a world of
// several organs and every loop step theirs; the raw forces the caller holds on nodes are the
// body's driver.held_forces (the tools add to them).
struct PySimulation {
  world::World world;
  world::WorldStepStats stats;  // the last world step's (its vectors reused step to step)
  sim::StepStats last;
  std::string scene;  // the scene it came from, if any
  // W x per embedded surface, refreshed by embedded_positions(); sized once when made, so each
  // buffer stays where the views handed out point.
  std::vector<Eigen::MatrixX3d> embedded_x;
  // What a cut replaced, kept: numpy views taken before it point into these buffers (they
  // show the state before the cut, never freed memory).
  struct Retired {
    std::shared_ptr<const Model> model;
    std::unique_ptr<sim::Simulation> sim;
    interact::ToolDriver driver;
  };
  std::vector<Retired> retired;

  world::Body& body() { return world.bodies.front().body; }
  const world::Body& body() const { return world.bodies.front().body; }
  sim::Simulation& sim() { return body().sim; }
  const sim::Simulation& sim() const { return body().sim; }
  interact::ToolDriver& driver() { return body().tools; }
  const interact::ToolDriver& driver() const { return body().tools; }
  const Model& model() const { return *body().model; }
  // Python's Model is held by shared_ptr<Model> (it exposes no setter: nothing changes it).
  std::shared_ptr<Model> shared_model() const {
    return std::const_pointer_cast<Model>(body().model);
  }
};

std::unique_ptr<PySimulation> make_py_simulation(std::shared_ptr<const Model> model,
                                                 sim::Simulation sim, interact::ToolDriver driver,
                                                 std::string scene) {
  auto p = std::make_unique<PySimulation>();
  p->world = world::one_body_world({.name = "organ",
                                    .model = std::move(model),
                                    .simulation = std::move(sim),
                                    .tools = std::move(driver)});
  p->scene = std::move(scene);
  p->driver().held_forces = Eigen::MatrixX3d::Zero(p->model().node_count(), 3);
  p->embedded_x.resize(p->model().embedded.size());
  return p;
}

// One step of the organ: the world's (its tools, then the solve: as the simulation alone).
sim::StepStats step_once(PySimulation& p) {
  world::step(p.world, p.stats);
  return p.stats.bodies.front().sim;
}

sim::Integrator parse_integrator(const std::string& name) {
  for (auto i : {sim::Integrator::kSemiImplicitEuler, sim::Integrator::kImplicitEuler,
                 sim::Integrator::kProjective})
    if (io::integrator_name(i) == name) return i;
  throw invalid_input(
      "integrator",
      "is '" + name + "'; semi_implicit_euler, implicit_euler or projective expected");
}

sim::Mode parse_mode(const std::string& name) {
  for (auto mode : {sim::Mode::kGlobal, sim::Mode::kLocal})
    if (io::mode_name(mode) == name) return mode;
  throw invalid_input("mode", "is '" + name + "'; global or local expected");
}

sim::Preconditioner parse_preconditioner(const std::string& name) {
  for (auto p :
       {sim::Preconditioner::kAuto, sim::Preconditioner::kJacobi, sim::Preconditioner::kMultigrid})
    if (io::preconditioner_name(p) == name) return p;
  throw invalid_input("preconditioner", "is '" + name + "'; auto, jacobi or multigrid expected");
}

sim::TetModel parse_tet_model(const std::string& name) {
  for (auto t : {sim::TetModel::kSprings, sim::TetModel::kNeoHookean})
    if (io::tet_model_name(t) == name) return t;
  throw invalid_input("tet_model", "is '" + name + "'; springs or neo_hookean expected");
}

interact::Routing parse_routing(const std::string& name) {
  for (auto r : {interact::Routing::kNone, interact::Routing::kPaper})
    if (io::routing_name(r) == name) return r;
  throw invalid_input("routing", "is '" + name + "'; none or paper expected");
}

interact::Touch parse_touch(const std::string& name) {
  for (auto t : {interact::Touch::kDisplaySkin, interact::Touch::kSkin})
    if (io::touch_name(t) == name) return t;
  throw invalid_input("touch", "is '" + name + "'; display_skin or skin expected");
}

// The embedded surface an index or a name selects: IndexError / KeyError listing the names.
size_t embedded_index(const Model& model, const std::variant<int64_t, std::string>& which) {
  std::string names;
  for (const EmbeddedSurface& e : model.embedded)
    names += (names.empty() ? "'" : ", '") + e.name + "'";
  const std::string known = model.embedded.empty() ? "the model has no embedded surfaces"
                                                   : "the model's embedded surfaces are " + names;
  const int64_t count = static_cast<int64_t>(model.embedded.size());
  if (const int64_t* k = std::get_if<int64_t>(&which)) {
    if (*k < 0 || *k >= count)
      throw py::index_error(
          fmt::format("embedded_positions: surface {} is not 0..{}; {}", *k, count - 1, known));
    return static_cast<size_t>(*k);
  }
  const std::string& name = std::get<std::string>(which);
  for (size_t k = 0; k < model.embedded.size(); ++k)
    if (model.embedded[k].name == name) return k;
  throw py::key_error(fmt::format("embedded_positions: no surface '{}'; {}", name, known));
}

// An unstable simulation is an error in Python, never a StepStats to overlook: lamina.Error
// (kind 'unstable'); the state stays readable and reset() starts again.
void throw_if_unstable(const PySimulation& p, const char* what) {
  if (p.last.unstable == sim::Instability::kNone) return;
  throw Error(ErrorKind::kUnstable,
              fmt::format("{}: unstable at t = {:.4g} s: {}; lower dt, the tool forces or the "
                          "stiffness, then reset()",
                          what, p.sim().time_s, sim::describe(p.last.unstable)));
}

sim::StepStats step_n(PySimulation& p, int64_t steps) {
  if (steps < 0)
    throw invalid_input("step: steps", "is " + std::to_string(steps) + "; >= 0 expected");
  {
    py::gil_scoped_release release;
    for (int64_t k = 0; k < steps; ++k) {
      p.last = step_once(p);
      if (p.last.unstable != sim::Instability::kNone) break;
    }
  }
  throw_if_unstable(p, "step");
  return p.last;
}

// Node indices from Python ints. One past int32 would wrap to a real node: refused instead (the
// library then checks the range against the model).
std::vector<int32_t> nodes_of(const std::vector<int64_t>& in) {
  std::vector<int32_t> out(in.size());
  for (size_t k = 0; k < in.size(); ++k) {
    if (in[k] < std::numeric_limits<int32_t>::min() || in[k] > std::numeric_limits<int32_t>::max())
      throw invalid_input("nodes[" + std::to_string(k) + "]",
                          "is " + std::to_string(in[k]) + ", not a node index");
    out[k] = static_cast<int32_t>(in[k]);
  }
  return out;
}

// The peaks over a run, which its last step does not show.
struct Peaks {
  double displacement_mm = 0.0, abs_volume_change_pct = 0.0, reaction_mn = 0.0;
};

py::dict run_dict(const PySimulation& p, const interact::ToolRun& run, const Peaks& peaks) {
  py::dict d;
  d["steps"] = run.steps;
  d["converged"] = run.converged;
  d["time_s"] = p.sim().time_s;
  d["max_displacement_mm"] = run.last.max_displacement_mm;
  d["volume_change_pct"] = run.last.volume_change_pct;
  d["recoveries"] = p.sim().recoveries;
  d["peak_displacement_mm"] = peaks.displacement_mm;
  d["peak_abs_volume_change_pct"] = peaks.abs_volume_change_pct;
  d["max_reaction_mn"] = peaks.reaction_mn;
  return d;
}

}  // namespace

// The boundary: fixed, held, released and supported nodes.
static void bind_simulation_tools(py::class_<PySimulation>& simulation) {
  simulation
      .def(
          "fix_nodes",
          [](PySimulation& p, const std::vector<int64_t>& n) {
            sim::fix_nodes(p.sim(), nodes_of(n));
          },
          py::arg("nodes"), "Holds these nodes at their rest positions from now on.")
      .def(
          "hold_nodes",
          [](PySimulation& p, const std::vector<int64_t>& n, const Eigen::MatrixX3d& x) {
            sim::hold_nodes(p.sim(), nodes_of(n), x);
          },
          py::arg("nodes"), py::arg("positions_mm"),
          "Holds these nodes at (len(nodes), 3) positions, mm.")
      .def(
          "release_nodes",
          [](PySimulation& p, const std::vector<int64_t>& n) {
            sim::release_nodes(p.sim(), nodes_of(n));
          },
          py::arg("nodes"), "Lets held or fixed nodes move again.")
      .def(
          "support_nodes",
          [](PySimulation& p, const std::vector<int64_t>& n, const std::vector<double>& k) {
            sim::support_nodes(p.sim(), nodes_of(n), k);
          },
          py::arg("nodes"), py::arg("stiffness_n_per_m"),
          "Ties each node to its rest position by a spring, N/m.");
}

// The tools: forces and graspers on the skin, lifted, and the step they act in.
static void bind_simulation_tool_list(py::class_<PySimulation>& simulation) {
  simulation
      .def(
          "add_tool",
          [](PySimulation& p, std::optional<Eigen::Vector3d> point_mm,
             std::optional<int32_t> vertex, const Eigen::Vector3d& force_mn,
             std::optional<double> start_s, double end_s, double radius_mm) {
            p.driver().tools.push_back(tool_from("add_tool", point_mm, vertex, force_mn, start_s,
                                                 end_s, radius_mm, p.sim().time_s));
            return p.driver().tools.size() - 1;
          },
          py::kw_only(), py::arg("point_mm") = py::none(), py::arg("vertex") = py::none(),
          py::arg("force_mn"), py::arg("start_s") = py::none(),
          py::arg("end_s") = std::numeric_limits<double>::infinity(),
          py::arg("radius_mm") = interact::kDefaultPatchRadiusMm,
          "A tool: touches the skin nearest point_mm (or skin node `vertex`) and pushes with\n"
          "force_mn (mN, 3 values) from start_s (default: now) until end_s. Without routing\n"
          "(the physical tissue's default) the force is spread over the skin within radius_mm\n"
          "of the contact, and the tissue's load is exactly the force; with routing='paper' it\n"
          "is routed over the contact's rings and the layers behind it. Returns its index.")
      .def(
          "add_grasp",
          [](PySimulation& p, std::optional<Eigen::Vector3d> point_mm,
             std::optional<int32_t> vertex, const Eigen::Vector3d& pull_mm, double pull_s,
             std::optional<double> start_s, double end_s, double radius_mm) {
            p.driver().tools.push_back(grasp_from("add_grasp", point_mm, vertex, pull_mm, pull_s,
                                                  start_s, end_s, radius_mm, p.sim().time_s));
            return p.driver().tools.size() - 1;
          },
          py::kw_only(), py::arg("point_mm") = py::none(), py::arg("vertex") = py::none(),
          py::arg("pull_mm") = Eigen::Vector3d::Zero(), py::arg("pull_s") = 1.0,
          py::arg("start_s") = py::none(),
          py::arg("end_s") = std::numeric_limits<double>::infinity(), py::arg("radius_mm") = 4.0,
          "A grasper: from start_s (default: now) its jaws hold every free skin node within\n"
          "radius_mm of point_mm (or of skin node `vertex`), move by pull_mm (mm) over pull_s\n"
          "and hold there, and let go at end_s. With nothing under the jaws the step that closes\n"
          "them raises lamina.Error. reaction_force_mn() includes its pull. Returns its index.")
      .def(
          "clear_tools",
          [](PySimulation& p) {
            for (interact::Grasp& g : p.driver().grasps) interact::open_jaws(p.sim(), g);
            p.driver().tools.clear();
            p.driver().routes.clear();
            p.driver().active.clear();
            p.driver().grasps.clear();
          },
          "Lifts every tool off (graspers let go).")
      .def_property_readonly("tool_count",
                             [](const PySimulation& p) { return p.driver().tools.size(); })
      .def("step", &step_n, py::arg("steps") = 1,
           "Takes `steps` steps with the tools and raw forces; returns the last StepStats.");
}

// Serving, and running to rest.
static void bind_simulation_runs(py::class_<PySimulation>& simulation) {
  simulation
      .def(
          "serve",
          [](const PySimulation& p, const py::kwargs& kwargs) {
            const net::ServeOptions o = serve_options(kwargs);
            const std::string source = p.scene.empty() ? "a Python simulation" : p.scene;
            // Listening first, as `lamina serve` does: a port in use fails before anything.
            net::Listening listening(o, /*igtl=*/true);
            if (listening.web_url().size()) py::print("the page is at", listening.web_url());
            sim::Simulation copy = p.sim();  // served from its state now; this one is unchanged
            return serve_until_interrupted([&](const net::KeepGoing& keep_going) {
              return net::serve_organ(listening, std::move(copy), p.body().model,
                                      p.driver().routing, o, source, keep_going);
            });
          },
          "Serves a copy of the simulation in its state now, in real time, as `lamina serve`\n"
          "does (docs/openigtlink.md, docs/web.md): 3D Slicer's OpenIGTLink on `port`, and\n"
          "with web=True the page for a browser or headset on `web_port`, its address\n"
          "printed. Keywords are lamina serve's options (port, web, web_port, web_host,\n"
          "duration_s, rate_hz, auto_rate, send_hz, max_force_n, self_signed, ...:\n"
          "docs/python.md). Runs until duration_s (0: until Ctrl-C, then\n"
          "KeyboardInterrupt). Returns 0, or 5 when the simulation blew up (each blow-up is\n"
          "logged and the organ reset). This simulation is not stepped; its tools are not\n"
          "used (the clients drive the tool).")
      .def(
          "run",
          [](PySimulation& p, double until_s, bool stop_at_rest, bool record) {
            interact::ToolRun run;
            Peaks peaks;
            // record: one row per step, gathered here and handed to numpy as arrays.
            std::vector<double> t, disp, vol, energy;
            std::vector<Eigen::Vector3d> reaction;
            {
              py::gil_scoped_release release;
              run = interact::run_tools(
                  p.sim(), p.driver(), until_s, stop_at_rest,
                  [&](const sim::Simulation& s, const interact::ToolDriver& d,
                      const sim::StepStats& st) {
                    peaks.displacement_mm = std::max(peaks.displacement_mm, st.max_displacement_mm);
                    peaks.abs_volume_change_pct =
                        std::max(peaks.abs_volume_change_pct, std::abs(st.volume_change_pct));
                    const Eigen::Vector3d r = interact::tools_reaction(s, d);
                    peaks.reaction_mn = std::max(peaks.reaction_mn, r.norm());
                    if (!record) return;
                    t.push_back(s.time_s);
                    disp.push_back(st.max_displacement_mm);
                    vol.push_back(st.volume_change_pct);
                    energy.push_back(st.kinetic_energy_j);
                    reaction.push_back(r);
                  },
                  [&p] { return step_once(p); });
            }
            p.last = run.last;
            throw_if_unstable(p, "run");
            py::dict d = run_dict(p, run, peaks);
            if (record) {
              py::dict metrics;
              metrics["time_s"] = py::array_t<double>(t.size(), t.data());
              metrics["max_displacement_mm"] = py::array_t<double>(disp.size(), disp.data());
              metrics["volume_change_pct"] = py::array_t<double>(vol.size(), vol.data());
              metrics["kinetic_energy_j"] = py::array_t<double>(energy.size(), energy.data());
              py::array_t<double> r({static_cast<py::ssize_t>(reaction.size()), py::ssize_t{3}});
              auto rw = r.mutable_unchecked<2>();
              for (size_t k = 0; k < reaction.size(); ++k)
                for (int c = 0; c < 3; ++c) rw(k, c) = reaction[k][c];
              metrics["reaction_mn"] = r;
              d["metrics"] = metrics;
            }
            return d;
          },
          py::arg("until_s") = std::numeric_limits<double>::infinity(),
          py::arg("stop_at_rest") = true, py::arg("record") = false,
          "Steps until every tool has ended and the model has rested for 0.1 s (stop_at_rest),\n"
          "or until simulated time until_s or the solver's max_steps. Returns a dict: steps,\n"
          "converged, time_s, max_displacement_mm and volume_change_pct (the last step's),\n"
          "recoveries, and over the run peak_displacement_mm, peak_abs_volume_change_pct and\n"
          "max_reaction_mn. record=True adds 'metrics': per-step numpy arrays time_s,\n"
          "max_displacement_mm, volume_change_pct, kinetic_energy_j (steps,) and reaction_mn\n"
          "(steps, 3), as lamina run's metrics.csv.");
}

// The reaction on the tools, a cut, a reset.
static void bind_simulation_changes(py::class_<PySimulation>& simulation) {
  simulation
      .def(
          "reaction_force_mn",
          [](const PySimulation& p) {
            return Eigen::Vector3d(interact::tools_reaction(p.sim(), p.driver()));
          },
          "the tissue's push back on the tools in the last step, mN (3 values)")
      .def(
          "cut",
          [](PySimulation& p, const std::vector<Eigen::Vector3d>& path, double depth_mm,
             const Eigen::Vector3d& direction) {
            // The body is cut in a copy of its state: numpy views taken before keep the
            // buffers they had, which show the state before the cut (kept in p.retired).
            world::Body& b = p.body();
            PySimulation::Retired kept{b.model, std::make_unique<sim::Simulation>(b.sim), b.tools};
            std::swap(*kept.sim, b.sim);
            std::swap(kept.driver, b.tools);
            const auto put_back = [&] {  // nothing was cut: the body keeps its own buffers
              std::swap(*kept.sim, b.sim);
              std::swap(kept.driver, b.tools);
            };
            std::vector<int32_t> origin;
            model::CutReport r;
            try {
              py::gil_scoped_release release;
              r = world::cut_body(p.world, world::body_ids(p.world).front(), path, direction,
                                  depth_mm, &origin);
            } catch (...) {
              put_back();
              throw;
            }
            if (r.cut_tets > 0) {
              p.retired.push_back(std::move(kept));
              // A buffer for the wound, which the cut adds (the others' buffers move with their
              // matrices: views taken before stay valid).
              p.embedded_x.resize(p.model().embedded.size());
            } else {
              put_back();
            }
            py::dict d;
            d["cut_tets"] = r.cut_tets;
            d["partly_cut_tets"] = r.partly_cut_tets;
            d["new_nodes"] = r.new_nodes;
            py::list pieces;
            for (const model::CutPiece& q : r.pieces) {
              py::dict pd;
              pd["volume_ml"] = q.volume_mm3 / 1000.0;
              pd["mass_g"] = q.mass_kg * 1000.0;
              pd["tets"] = q.tets;
              pd["nodes"] = q.nodes;
              pieces.append(pd);
            }
            d["pieces"] = pieces;
            py::list crossed;
            for (const model::StructureCut& c : r.structures_cut) {
              py::dict cd;
              cd["name"] = c.name;
              cd["role"] = std::string(role_name(c.role));
              cd["label"] = c.label;
              cd["position_mm"] = Eigen::Vector3d(c.position_mm);
              cd["diameter_mm"] = c.diameter_mm;
              cd["area_mm2"] = c.area_mm2;
              cd["closed"] = c.closed;
              crossed.append(cd);
            }
            d["structures_cut"] = crossed;
            d["origin"] =
                py::array_t<int32_t>(static_cast<py::ssize_t>(origin.size()), origin.data());
            return d;
          },
          py::arg("path"), py::arg("depth_mm"), py::arg("direction"),
          "Cuts the model at once with a scalpel drawn at the current positions: its blade's\n"
          "upper end along `path` ((k, 3) mm, k >= 2), reaching depth_mm along `direction` (into\n"
          "the tissue). The tetrahedra the blade divides become two copies each (the virtual\n"
          "node algorithm): the model, x, v and f_ext then have more nodes (arrays taken before\n"
          "show the state before the cut; take them again), the tools act on the copies.\n"
          "Returns a dict: cut_tets, partly_cut_tets, new_nodes, pieces (volume_ml, mass_g, tets,\n"
          "nodes; largest first), structures_cut (name, label, position_mm, diameter_mm,\n"
          "area_mm2, closed: each embedded vessel or tumour cut across) and origin (the node\n"
          "before the cut each node came from). Raises lamina.Error for a bad path, depth or\n"
          "direction, or a model without tetrahedra; nothing changes then.")
      .def(
          "reset",
          [](PySimulation& p) {
            sim::reset(p.sim());  // tools and raw forces kept, unlike world::reset()
            p.world.time_s = 0.0;
            p.world.steps = 0;
            p.last = {};
          },
          "Every node back at rest, time 0; parameters, fixed nodes and tools kept.")
      .def_property_readonly("scene", [](const PySimulation& p) { return p.scene; });
}

// What one step measured.
static void bind_step_stats(py::module_& m) {
  py::class_<sim::StepStats>(m, "StepStats", "What one step measured (mm, mm/s, J, us)")
      .def_readonly("max_move_mm", &sim::StepStats::max_move_mm)
      .def_readonly("max_speed_mm_per_s", &sim::StepStats::max_speed_mm_per_s)
      .def_readonly("max_displacement_mm", &sim::StepStats::max_displacement_mm)
      .def_readonly("skin_volume_mm3", &sim::StepStats::skin_volume_mm3)
      .def_readonly("volume_change_pct", &sim::StepStats::volume_change_pct)
      .def_readonly("kinetic_energy_j", &sim::StepStats::kinetic_energy_j)
      .def_readonly("step_us", &sim::StepStats::step_us)
      .def_readonly("cg_iterations", &sim::StepStats::cg_iterations)
      .def_readonly("converged", &sim::StepStats::converged,
                    "at rest: no node faster than the rest speed")
      .def_readonly("recovered", &sim::StepStats::recovered)
      .def_readonly("failed", &sim::StepStats::failed)
      .def_property_readonly(
          "unstable",
          [](const sim::StepStats& s) {
            return s.unstable == sim::Instability::kNone ? "" : sim::describe(s.unstable);
          },
          "why the simulation left physical bounds; empty while it is stable")
      .def_readonly("solver_converged", &sim::StepStats::solver_converged,
                    "implicit Euler: conjugate gradients reached their tolerance")
      .def_readonly("solver_residual", &sim::StepStats::solver_residual,
                    "implicit Euler: |b - A dv| / |b| at the solve's end")
      .def_readonly("step_fraction", &sim::StepStats::step_fraction,
                    "implicit Euler: the fraction of the solved step taken (1 unless it would "
                    "have collapsed a tetrahedron)")
      .def("__repr__", [](const sim::StepStats& s) {
        return "<lamina.StepStats max_displacement_mm=" + std::to_string(s.max_displacement_mm) +
               " volume_change_pct=" + std::to_string(s.volume_change_pct) +
               (s.converged ? " at rest>" : ">");
      });
}

// The module's functions that make and run simulations from scenes.
static void bind_scene_functions(py::module_& m) {
  m.def(
      "scene_simulation",
      [](const py::object& what, bool paper) {
        // A dict is a scene file's content (docs/scenes.md), paths in it as the caller's.
        io::Scene scene =
            py::isinstance<py::dict>(what)
                ? io::parse_scene(
                      py::module_::import("json").attr("dumps")(what).cast<std::string>(),
                      "scene dict")
                : io::scene_for(what.cast<std::string>(), paper);
        io::ReadyScene ready = [&] {
          py::gil_scoped_release release;
          return io::make_ready_scene(scene);
        }();
        return make_py_simulation(ready.model, io::make_scene_simulation(ready),
                                  io::make_tool_driver(ready.scene), ready.scene.source);
      },
      py::arg("scene") = "phantom", py::kw_only(), py::arg("paper") = false,
      "A simulation set up as `lamina run SCENE` sets it up: SCENE is a scene .json, a .vtu\n"
      "model, a mask or 'phantom' (the default scene: the physical liver, held at its back,\n"
      "one 0.4 N poke for 1 s), or a dict with a scene file's keys (docs/scenes.md). The\n"
      "scene's tools are loaded; run() plays them.");

  m.def(
      "nodes_near_plane",
      [](const Model& model, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
         double distance_mm) { return sim::nodes_near_plane(model, point, normal, distance_mm); },
      py::arg("model"), py::arg("point_mm"), py::arg("normal"), py::arg("distance_mm"),
      "Nodes within distance_mm of the plane through point_mm with this normal.");
}

void bind_simulation(py::module_& m) {
  bind_step_stats(m);

  py::class_<PySimulation> simulation(
      m, "Simulation",
      "Dynamics of a model: m x'' + gamma x' + f_internal(x) = f_ext.\n"
      "x, v, f_ext are (nodes, 3) float64 numpy views of the simulation's own\n"
      "memory (no copy): write them between steps. f_ext holds raw forces, mN;\n"
      "tools add their routed forces to them during each step.");
  simulation
      .def(py::init([](std::shared_ptr<Model> model, double stiffness_n_per_m,
                       double damping_kg_per_s, double mass_damping_per_s, double node_mass_kg,
                       double anchor_stiffness_n_per_m, double volume_stiffness_kpa,
                       double young_modulus_kpa, double poisson_ratio, const std::string& tet_model,
                       const Eigen::Vector3d& gravity_mm_per_s2, const std::string& integrator,
                       double dt_s, double rest_speed_mm_per_s, int64_t max_steps,
                       const std::string& mode, int32_t cg_max_iterations, double cg_tolerance,
                       const std::string& preconditioner, const std::optional<std::string>& routing,
                       int32_t locality, int32_t penetration_depth, double contact_threshold_mm,
                       const std::string& touch, const py::object& ring_spacing_mm,
                       const std::vector<int64_t>& fixed) {
             if (!model) throw invalid_input("Simulation: model", "is None");
             // Checked before the simulation is made (its solver setup can take seconds).
             // The physical tissue (E given) conserves force; the paper's constants route.
             const bool elastic = young_modulus_kpa > 0.0 && stiffness_n_per_m == 0.0;
             interact::RoutingOptions ro{
                 .routing = parse_routing(routing.value_or(elastic ? "none" : "paper")),
                 .locality = locality,
                 .penetration_depth = penetration_depth,
                 .contact_threshold_mm = contact_threshold_mm,
                 .touch = parse_touch(touch)};
             // A length in mm, or "paper": the organ's paper-size skin's edge.
             if (py::isinstance<py::str>(ring_spacing_mm)) {
               if (ring_spacing_mm.cast<std::string>() != "paper")
                 throw invalid_input("Simulation: ring_spacing_mm",
                                     "expected a number of mm or \"paper\", got \"" +
                                         ring_spacing_mm.cast<std::string>() + "\"");
               ro.ring_spacing_mm = interact::kPaperRingSpacing;
             } else {
               ro.ring_spacing_mm = ring_spacing_mm.cast<double>();
             }
             interact::check_routing(ro, model->rings.locality);
             ro = interact::resolve_ring_spacing(ro, *model);
             sim::Material mat{.stiffness_n_per_m = stiffness_n_per_m,
                               .damping_kg_per_s = damping_kg_per_s,
                               .mass_damping_per_s = mass_damping_per_s,
                               .node_mass_kg = node_mass_kg,
                               .anchor_stiffness_n_per_m = anchor_stiffness_n_per_m,
                               .volume_stiffness_kpa = volume_stiffness_kpa,
                               .young_modulus_kpa = young_modulus_kpa,
                               .poisson_ratio = poisson_ratio,
                               .tet_model = parse_tet_model(tet_model),
                               .gravity_mm_per_s2 = gravity_mm_per_s2};
             sim::SolverOptions opt{.integrator = parse_integrator(integrator),
                                    .dt_s = dt_s,
                                    .rest_speed_mm_per_s = rest_speed_mm_per_s,
                                    .max_steps = max_steps,
                                    .mode = parse_mode(mode),
                                    .cg_max_iterations = cg_max_iterations,
                                    .cg_tolerance = cg_tolerance,
                                    .preconditioner = parse_preconditioner(preconditioner)};
             sim::Simulation s = sim::make_simulation(*model, mat, opt);
             sim::fix_nodes(s, nodes_of(fixed));
             sim::prepare_solver(s);  // the multigrid now, not in the first step
             return make_py_simulation(model, std::move(s), interact::ToolDriver{.routing = ro},
                                       {});
           }),
           py::arg("model"), py::kw_only(), py::arg("stiffness_n_per_m") = 3.0,
           py::arg("damping_kg_per_s") = 3.0, py::arg("mass_damping_per_s") = 0.0,
           py::arg("node_mass_kg") = 1.0, py::arg("anchor_stiffness_n_per_m") = 0.0,
           py::arg("volume_stiffness_kpa") = 0.0, py::arg("young_modulus_kpa") = 0.0,
           py::arg("poisson_ratio") = 0.45, py::arg("tet_model") = "springs",
           py::arg("gravity_mm_per_s2") = Eigen::Vector3d::Zero(),
           py::arg("integrator") = "semi_implicit_euler", py::arg("dt_s") = 0.01,
           py::arg("rest_speed_mm_per_s") = 0.1, py::arg("max_steps") = 100000,
           py::arg("mode") = "global", py::arg("cg_max_iterations") = 100,
           py::arg("cg_tolerance") = 1e-6, py::arg("preconditioner") = "auto",
           py::arg("routing") = py::none(), py::arg("locality") = 4,
           py::arg("penetration_depth") = 4, py::arg("contact_threshold_mm") = 10.0,
           py::arg("touch") = "display_skin", py::arg("ring_spacing_mm") = 0.0,
           py::arg("fixed") = std::vector<int64_t>{},
           "A simulation at rest. Defaults are the reference paper's (K = 3 N/m, gamma = 3 kg/s,\n"
           "unit masses, semi-implicit Euler at dt = 0.01 s). young_modulus_kpa (E) > 0 with\n"
           "stiffness_n_per_m = 0 and node_mass_kg = 0 makes the tissue elastic (E, nu) through\n"
           "the tetrahedra; tet_model: springs (coupled edge springs and volume) or neo_hookean\n"
           "(stable Neo-Hookean). integrator: semi_implicit_euler, implicit_euler, projective.\n"
           "preconditioner (implicit_euler's CG): auto (Jacobi or multigrid by a trial solve), "
           "jacobi, "
           "multigrid.\n"
           "routing: none (a tool's force spread over the skin it touches, conserved; the\n"
           "default with young_modulus_kpa) or paper (the paper's rings and copies; the default\n"
           "with its constants).\n"
           "ring_spacing_mm: 0 (the paper's rings, counted in mesh edges), a length in mm (rings\n"
           "by distance along the skin at rest: the same area at every mesh size), or \"paper\"\n"
           "(the edge of this organ's paper-size skin).\n"
           "touch: display_skin (without routing, tools touch the model's display skin when it\n"
           "has one; its load reaches the nodes by the embedding's weights) or skin.\n"
           "fixed: node indices held at rest (without them a push moves the organ bodily).")
      .def_property_readonly("model", [](const PySimulation& p) { return p.shared_model(); })
      .def_property(
          "x", [](PySimulation& p) -> Eigen::MatrixX3d& { return p.sim().x; },
          [](PySimulation& p, const Eigen::MatrixX3d& x) { p.sim().x = x; },
          py::return_value_policy::reference_internal, "positions, (nodes, 3) mm, a view")
      .def_property(
          "v", [](PySimulation& p) -> Eigen::MatrixX3d& { return p.sim().v; },
          [](PySimulation& p, const Eigen::MatrixX3d& v) { p.sim().v = v; },
          py::return_value_policy::reference_internal, "velocities, (nodes, 3) mm/s, a view")
      .def_property(
          "f_ext", [](PySimulation& p) -> Eigen::MatrixX3d& { return p.driver().held_forces; },
          [](PySimulation& p, const Eigen::MatrixX3d& f) { p.driver().held_forces = f; },
          py::return_value_policy::reference_internal,
          "raw external forces held on nodes, (nodes, 3) mN, a view; kept from step to step")
      .def(
          "embedded_positions",
          [](py::object self, const std::variant<int64_t, std::string>& which) {
            PySimulation& p = self.cast<PySimulation&>();
            const size_t k = embedded_index(p.model(), which);
            Eigen::MatrixX3d& out = p.embedded_x[k];
            {
              py::gil_scoped_release release;
              model::embedded_positions(p.model().embedded[k], p.sim().x, out);
            }
            return matrix_view(out, self);
          },
          py::arg("surface"),
          "Embedded surface `surface` (an index into model.embedded or its name) at the current\n"
          "positions: W x, (vertices, 3) float64, mm, a read-only view of a buffer this\n"
          "simulation keeps per surface. The next call for that surface overwrites it (copy to\n"
          "keep one); valid while the simulation lives. Only the first call for a surface\n"
          "allocates. A bad index raises IndexError, a bad name KeyError, naming the surfaces.")
      .def_property_readonly("time_s", [](const PySimulation& p) { return p.sim().time_s; })
      .def_property_readonly("steps", [](const PySimulation& p) { return p.sim().steps; })
      .def_property_readonly("recoveries", [](const PySimulation& p) { return p.sim().recoveries; })
      .def_property_readonly(
          "stats", [](const PySimulation& p) { return p.last; }, "the last step's StepStats")
      .def_property_readonly("dt_s", [](const PySimulation& p) { return p.sim().options().dt_s; })
      .def_property_readonly(
          "fixed",
          [](const PySimulation& p) {
            std::vector<int32_t> out;
            for (size_t i = 0; i < p.sim().fixed().size(); ++i)
              if (p.sim().fixed()[i]) out.push_back(static_cast<int32_t>(i));
            return out;
          },
          "indices of the nodes held where they are");
  bind_simulation_tools(simulation);
  bind_simulation_tool_list(simulation);
  bind_simulation_runs(simulation);
  bind_simulation_changes(simulation);
  bind_scene_functions(m);
}

}  // namespace lamina::python
