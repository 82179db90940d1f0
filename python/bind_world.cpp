// Worlds of several organs (docs/world.md, docs/python.md): a world scene made ready as
// `lamina run` makes it, stepped from Python, each body's positions as numpy views.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <memory>
#include <string>

#include "bindings.h"
#include "lamina/io/world_scene.h"
#include "lamina/model/summarize_model.h"
#include "lamina/world/cut_body.h"
#include "lamina/world/dissection.h"
#include "lamina/world/world.h"
#include "py_world.h"

namespace py = pybind11;

namespace lamina::python {

PyWorld::Retired& retire(PyWorld& w, world::Body& b) {
  auto kept = std::make_unique<sim::Simulation>(b.sim);
  std::swap(*kept, b.sim);  // the body steps a copy; the views keep the buffers they had
  w.retired.push_back({b.model, std::move(kept)});
  return w.retired.back();
}

world::Body& body_named(PyWorld& w, const std::string& name) {
  const world::BodyId id = world::find_body(w.ready->world, name);
  if (id.index < 0) {
    std::string known;
    for (const world::BodyId b : w.ready->ids)
      known += (known.empty() ? "" : ", ") + world::body(w.ready->world, b).name;
    throw invalid_input("world", "no body is named '" + name + "' (the bodies: " + known + ")");
  }
  return world::body(w.ready->world, id);
}

const world::Body& body_named(const PyWorld& w, const std::string& name) {
  return body_named(const_cast<PyWorld&>(w), name);
}

namespace {

py::dict stats_dict(const PyWorld& w) {
  const world::WorldStepStats& st = w.last;
  py::list bodies;
  for (size_t k = 0; k < st.bodies.size() && k < w.ready->ids.size(); ++k) {
    const world::BodyStepStats& b = st.bodies[k];
    py::dict d;
    d["name"] = world::body(w.ready->world, w.ready->ids[k]).name;
    d["max_displacement_mm"] = b.sim.max_displacement_mm;
    d["volume_change_pct"] = b.sim.volume_change_pct;
    d["max_speed_mm_per_s"] = b.sim.max_speed_mm_per_s;
    d["max_penetration_mm"] = b.max_penetration_mm;
    d["contacts"] = b.contacts + b.self_contacts;
    d["contact_force_mn"] = Eigen::Vector3d(b.contact_force_mn);
    d["attachment_force_mn"] = Eigen::Vector3d(b.attachment_force_mn);
    d["converged"] = b.sim.converged;
    bodies.append(d);
  }
  const world::TieCount ties = world::count_ties(w.ready->world);
  py::dict out;
  out["time_s"] = w.ready->world.time_s;
  out["steps"] = w.ready->world.steps;
  out["step_us"] = st.step_us;
  out["contact_us"] = st.profile.contact_us;
  out["solve_us"] = st.profile.solve_us;
  out["converged"] = st.converged;
  out["unstable"] = st.unstable != sim::Instability::kNone;
  out["unstable_body"] = st.unstable_body;
  out["ties"] = py::dict(py::arg("total") = ties.total, py::arg("divided") = ties.divided,
                         py::arg("torn") = ties.torn);
  out["bodies"] = bodies;
  return out;
}

// World.cut (a scalpel through every body it passes, the views taken before kept valid) and
// World.serve (the scene's world on the web page).
static void bind_world_cut_and_serve(py::class_<PyWorld>& world) {
  world
      .def(
          "cut",
          [](PyWorld& w, const std::vector<Eigen::Vector3d>& path, double depth_mm,
             const Eigen::Vector3d& direction) {
            world::World& world = w.ready->world;
            world::WorldCut c;
            {
              py::gil_scoped_release release;
              world::check_stroke("cut", path, direction, depth_mm, 1.5);  // before any copy
              // Every body's buffers kept for the views taken before; given back to the bodies
              // the blade did not divide.
              const size_t first = w.retired.size();
              for (const world::BodyId id : w.ready->ids) retire(w, world::body(world, id));
              const auto was_divided = world::divided_flags(world);
              world::CutUndo undo;  // what undo_cut() takes back
              c = world::cut_through(world, path, direction, depth_mm, 1.5, undo.before);
              if (!c.bodies.empty()) {
                for (const auto& [id, r] : c.bodies) undo.tets += r.cut_tets;
                undo.stroke_divided = world::divided_since(world, was_divided);
                world::push_cut(w.cuts, std::move(undo));
              }
              for (size_t k = w.ready->ids.size(); k-- > 0;) {
                const world::BodyId id = w.ready->ids[k];
                if (std::any_of(c.bodies.begin(), c.bodies.end(),
                                [&](const auto& b) { return b.first == id; }))
                  continue;
                std::swap(*w.retired[first + k].sim, world::body(world, id).sim);
                w.retired.erase(w.retired.begin() + static_cast<std::ptrdiff_t>(first + k));
              }
            }
            py::dict cut;
            for (const auto& [id, r] : c.bodies) {
              const world::Body& b = world::body(world, id);
              cut[py::str(b.name)] =
                  py::dict(py::arg("cut_tets") = r.cut_tets, py::arg("new_nodes") = r.new_nodes,
                           py::arg("topology") = b.topology);
            }
            return py::dict(py::arg("bodies") = cut, py::arg("ties_divided") = c.ties_divided,
                            py::arg("skipped") = c.skipped);
          },
          py::arg("path"), py::arg("depth_mm"), py::arg("direction"),
          "Cuts at once every body the blade passes through (a scalpel drawn at the current\n"
          "positions: its upper end along `path` ((k, 3) mm, k >= 2), reaching depth_mm along\n"
          "`direction`), and divides the ties within 1.5 mm of it. A body cut has more nodes\n"
          "(x, rest and skin_faces taken before show it as it was: take them again) and a new\n"
          "topology generation; its ties follow their nodes' copies (docs/world.md, \"Cutting a\n"
          "body\"). Returns {bodies: {name: {cut_tets, new_nodes, topology}} (the bodies cut),\n"
          "ties_divided, skipped (the bodies it could not cut: one without tetrahedra)}.\n"
          "Raises lamina.Error for a bad blade, nothing changed.")
      .def(
          "serve",
          [](const PyWorld& w, const py::kwargs& kwargs) {
            const net::ServeOptions o = serve_options(kwargs);
            net::Listening listening(o, /*igtl=*/true);
            if (!listening.web_url().empty()) py::print("the page is at", listening.web_url());
            std::unique_ptr<io::ReadyWorld> fresh = io::make_ready_world(w.scene);
            return serve_until_interrupted([&](const net::KeepGoing& keep_going) {
              return net::serve_world(listening, std::move(fresh->world), w.scene.dissections, o,
                                      w.scene.source, keep_going);
            });
          },
          "Serves the scene's world in real time, as `lamina serve SCENE` does: each body's\n"
          "skin over OpenIGTLink, the hands (tool, grasper, scalpel) on any body, and with\n"
          "web=True the page (docs/openigtlink.md, docs/web.md). Made again from its scene,\n"
          "at rest (this World is unchanged). Keywords as Simulation.serve's. Returns 0, or 5\n"
          "when a body blew up (which ends the serve).");
}

}  // namespace

void bind_world(py::module_& m) {
  py::class_<PyWorld> world(m, "World",
                            "Several organs stepped in one world: contact, attachments,\n"
                            "dissections (docs/world.md). Made by lamina.world_scene().");
  bind_world_cut_and_serve(world);
  world
      .def_property_readonly("bodies",
                             [](const PyWorld& w) {
                               std::vector<std::string> names;
                               for (const world::BodyId id : w.ready->ids)
                                 names.push_back(world::body(w.ready->world, id).name);
                               return names;
                             })
      .def_property_readonly("time_s", [](const PyWorld& w) { return w.ready->world.time_s; })
      .def_property_readonly("dt_s", [](const PyWorld& w) { return w.scene.solver.dt_s; })
      .def(
          "step",
          [](PyWorld& w, int64_t steps) {
            if (steps < 1) throw invalid_input("steps", "must be >= 1");
            {
              py::gil_scoped_release release;
              for (int64_t k = 0; k < steps; ++k) {
                const double t = w.ready->world.time_s;
                world::advance_dissections(w.scene.dissections, w.ready->world, t,
                                           t + w.scene.solver.dt_s);
                world::step(w.ready->world, w.last);
                if (w.last.unstable != sim::Instability::kNone) break;
              }
            }
            return stats_dict(w);
          },
          py::arg("steps") = 1,
          "Takes `steps` world steps (the dissections' blades moved, then tools, contact and\n"
          "ties, each body's solve); returns the last one's measures as a dict: time_s,\n"
          "step_us, contact_us, converged, unstable (it stops early when a body is),\n"
          "unstable_body, ties {total, divided, torn}, bodies [{name, max_displacement_mm,\n"
          "max_penetration_mm, contacts, contact_force_mn, attachment_force_mn, ...}].")
      .def(
          "x",
          [](py::object self, const std::string& name) {
            return matrix_view(body_named(self.cast<const PyWorld&>(), name).sim.x, self);
          },
          py::arg("body"), "Body `body`'s node positions, (nodes, 3) mm, a read-only view.")
      .def(
          "rest",
          [](py::object self, const std::string& name) {
            return matrix_view(body_named(self.cast<const PyWorld&>(), name).model->X, self);
          },
          py::arg("body"), "Body `body`'s rest positions, (nodes, 3) mm, a read-only view.")
      .def(
          "skin_faces",
          [](const PyWorld& w, const std::string& name) {
            return Eigen::MatrixX3i(model::layer_mesh(*body_named(w, name).model, 0).F);
          },
          py::arg("body"), "Body `body`'s skin triangles, rows of x() (its first nodes).")
      .def(
          "ties",
          [](const PyWorld& w) {
            const world::TieCount t = world::count_ties(w.ready->world);
            return py::dict(py::arg("total") = t.total, py::arg("divided") = t.divided,
                            py::arg("torn") = t.torn);
          },
          "The attachments' ties: total, divided by a blade, torn past their strength.")
      .def(
          "topology",
          [](const PyWorld& w, const std::string& name) { return body_named(w, name).topology; },
          py::arg("body"),
          "Body `body`'s topology generation: it moves on with each cut (and with a reset\n"
          "putting a cut body back), and node numbers of an older one name other nodes.")
      .def(
          "reset",
          [](PyWorld& w) {
            // The bodies cut since, their buffers kept for the views taken before.
            std::vector<int32_t> slots;
            const auto keep = [&](const world::WorldBefore& before) {
              for (const world::BodyBefore& k : before.bodies)
                if (world::is_valid(w.ready->world, k.id) &&
                    std::find(slots.begin(), slots.end(), k.id.index) == slots.end()) {
                  slots.push_back(k.id.index);
                  retire(w, world::body(w.ready->world, k.id));
                }
            };
            keep(w.cuts.oldest);
            for (const world::CutUndo& u : w.cuts.undo) keep(u.before);
            world::put_back_all(w.ready->world, w.cuts);
            world::reset(w.ready->world);
            w.last = {};
          },
          "Every body back at rest and uncut, every tie in place, time 0.");
  bind_world_edit(world);

  m.def(
      "world_scene",
      [](const py::object& what) {
        auto w = std::make_unique<PyWorld>();
        if (py::isinstance<py::dict>(what)) {
          // A dict is a world scene file's content (docs/scenes.md), paths as the caller's.
          w->scene = io::parse_world_scene(
              py::module_::import("json").attr("dumps")(what).cast<std::string>(),
              "world scene dict");
        } else {
          w->scene = io::load_world_scene(what.cast<std::string>());
        }
        py::gil_scoped_release release;
        w->ready = io::make_ready_world(w->scene);
        return w;
      },
      py::arg("scene"),
      "A world as `lamina run SCENE` makes it: SCENE is a world scene .json (one with\n"
      "\"bodies\", docs/scenes.md) or a dict with its keys. Every body's model is made and\n"
      "prepared, the bodies' places checked, the attachments tied.");
}

}  // namespace lamina::python
