// `lamina view` and `lamina render`: the interactive viewer and one picture without a window.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/io/scene.h"
#include "lamina/io/world_scene.h"
#include "lamina/model/embed_surface.h"
#include "lamina/render/camera.h"
#include "lamina/render/legend.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"
#include "lamina/render/viewer.h"
#include "lamina/sim/simulation.h"
#include "view_session.h"
#include "world_view.h"

namespace lamina::cli {
namespace {

// The scene named on the command line, ready: its model built or loaded, its defaults resolved.
// `cuts`: the caller plays the scene's scalpels (else a warning says they are ignored).
io::ReadyScene prepare(const std::string& what, const ProgressFn& progress, bool paper = false,
                       bool cuts = false) {
  io::ReadyScene ready =
      io::make_ready_scene(io::scene_for(what, paper), volume_read_options, progress);
  if (!cuts) io::warn_scalpels_ignored(ready.scene);
  return ready;
}

// "AZ,EL" or "AZ,EL,DIST" (degrees, degrees, mm); distance 0 = fit the organ.
struct CameraOption {
  double azimuth_deg = render::Camera{}.azimuth_deg, elevation_deg = render::Camera{}.elevation_deg;
  double distance_mm = 0.0;
};
CameraOption parse_camera(const std::string& text) {
  CameraOption c;
  if (text.empty()) return c;
  double az = 0, el = 0, dist = 0;
  char tail = 0;
  const int n = std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &az, &el, &dist, &tail);
  if ((n != 2 && n != 3) || !std::isfinite(az) || !std::isfinite(el) || el < -90 || el > 90 ||
      (n == 3 && !(dist > 0)))
    throw invalid_input("--camera",
                        "expected AZIMUTH,ELEVATION[,DISTANCE] in degrees and mm "
                        "(elevation -90..90, distance > 0), got '" +
                            text + "'");
  c.azimuth_deg = az;
  c.elevation_deg = el;
  if (n == 3) c.distance_mm = dist;
  return c;
}

// `lamina view SCENE.json` of a world scene: every body, their contact and ties, in one world
// stepping in its own thread (view/world_view.h).
int run_world_view(const ViewArgs& a, const ProgressFn& progress) {
  if (a.paper)
    throw invalid_input("--paper", "cannot be given with a world scene (" + a.what + ")");
  io::WorldScene scene = io::load_world_scene(a.what);
  std::unique_ptr<io::ReadyWorld> ready =
      io::make_ready_world(scene, volume_read_options, progress);
  WorldViewOptions o{.rate_hz = a.rate_hz,
                     .auto_rate = a.auto_rate,
                     .gain_n_per_mm = a.gain_n_per_mm,
                     .script = a.script,
                     .report = a.report};
  render::ViewerOptions window;
  window.width = a.size[0];
  window.height = a.size[1];
  window.title = "Lamina - " + scene.source;
  WorldViewSession session(std::move(o), std::move(scene), std::move(ready));
  window.platform_mouse = !session.script_drives_mouse();
  render::init(window);
  struct Shutdown {
    ~Shutdown() { render::shutdown(); }
  } engine_guard;
  return session.run();
}

}  // namespace

int run_view(const ViewArgs& a) {
  // Everything that can fail fast does, before the model is built.
  if (!(a.rate_hz >= 0.0) || a.rate_hz > 1e6)
    throw invalid_input("--rate", "must be 0..1e6 steps/s");
  if (!(a.gain_n_per_mm > 0.0) || a.gain_n_per_mm > 100.0)
    throw invalid_input("--gain", "must be in (0, 100] N/mm");
  if (!a.script.empty()) check_view_script(a.script);
  render::check_display();
  const ProgressFn progress = stderr_progress(a.verbose);
  if (io::is_world_scene_file(a.what)) return run_world_view(a, progress);
  io::ReadyScene p = prepare(a.what, progress, a.paper);
  const bool from_scene_file = a.what.ends_with(".json");

  ViewOptions o;
  o.rate_hz = a.rate_hz;
  o.auto_rate = a.auto_rate;
  o.gain_n_per_mm = a.gain_n_per_mm;
  o.material = p.scene.material;
  o.solver = p.scene.solver;
  o.routing = p.scene.routing;
  o.script = a.script;
  o.report = a.report;
  ViewModel vm;
  vm.source = p.source;
  vm.fixed = p.setup.fixed;
  vm.support = p.setup.support;
  // A scene file's tools act from the start, pinned; on a bare model the default poke's node is
  // only watched (plotted), and the user pushes.
  for (const interact::Tool& t : p.scene.tools) {
    if (t.grasp) {
      if (vm.grasper) {
        log::warn("{}: the viewer plays one grasper (the scene's first); the others are left out",
                  p.scene.source);
        continue;
      }
      vm.grasper = t;
      if (!t.by_point) vm.grasper->point_mm = p.model->X.row(t.vertex).transpose();
      if (vm.watched_node < 0)  // its displacement is what the plot shows
        vm.watched_node =
            t.by_point ? interact::nearest_skin_node(*p.model, p.model->X, t.point_mm, t.radius_mm)
                       : t.vertex;
      continue;
    }
    int32_t node = t.vertex;
    if (t.by_point)
      node = interact::nearest_skin_node(*p.model, p.model->X, t.point_mm,
                                         p.scene.routing.contact_threshold_mm);
    if (node < 0) continue;
    if (from_scene_file) vm.pinned.emplace_back(node, t.force_mn);
    if (vm.watched_node < 0) vm.watched_node = node;
  }
  vm.model = std::move(*p.model);
  if (!p.scene.input.empty()) {
    // Rebuilding re-reads the segmentation with the scene's options and its boundary rule.
    // The same preparation as the first model's (prepare_scene): fixed and supported nodes,
    // and the material resolved again, whose damping follows the new model's slowest vibration.
    o.rebuild = [scene = p.parsed](int32_t layers, int32_t skin_vertices, const ProgressFn& pr) {
      io::ReadyScene b =
          io::rebuild_ready_scene(scene, layers, skin_vertices, volume_read_options, pr);
      ViewModel out;
      out.fixed = b.setup.fixed;
      out.support = b.setup.support;
      out.material = b.scene.material;
      out.source = b.source;
      out.model = std::move(*b.model);  // b's only owner: no copy of the new model
      return out;
    };
  }
  // The session owns the simulation and drives the engine; the engine owns the window.
  render::ViewerOptions window;
  window.width = a.size[0];
  window.height = a.size[1];
  window.title = "Lamina - " + vm.source;
  ViewSession session(std::move(o), std::move(vm));
  window.platform_mouse = !session.script_drives_mouse();  // a script's mouse, not the window's
  render::init(window);
  struct Shutdown {
    ~Shutdown() { render::shutdown(); }
  } engine_guard;
  return session.run();
}

namespace {

// The model's default style (render::default_style: a translucent skin over its structures), then
// the options. The structures' names are checked against the model.
render::Style render_style(const RenderArgs& a, const Model& m, render::InnerLayers inner) {
  render::Style style = render::default_style(m);
  style.display_skin = a.display_skin == "on";
  const int32_t skin = model::display_skin_index(m);
  bool any = false;
  if (a.structures != "all") {
    std::vector<std::string> names;
    std::istringstream list(a.structures == "none" ? "" : a.structures);
    for (std::string n; std::getline(list, n, ',');) names.push_back(n);
    for (size_t i = 0; i < m.embedded.size(); ++i)
      style.embedded[i].visible = std::count(names.begin(), names.end(), m.embedded[i].name) > 0;
    for (const std::string& n : names) {
      const auto it = std::find_if(m.embedded.begin(), m.embedded.end(),
                                   [&](const EmbeddedSurface& e) { return e.name == n; });
      if (it == m.embedded.end() || it - m.embedded.begin() == skin) {
        std::string known;
        for (size_t i = 0; i < m.embedded.size(); ++i)
          if (static_cast<int32_t>(i) != skin)
            known += (known.empty() ? "" : ", ") + m.embedded[i].name;
        throw invalid_input("--structures", "the model has no structure '" + n + "' (it has: " +
                                                (known.empty() ? "none" : known) + ")");
      }
    }
  }
  for (size_t i = 0; i < m.embedded.size(); ++i)
    any = any || (static_cast<int32_t>(i) != skin && style.embedded[i].visible);
  style.inner = inner;
  style.skin_alpha = inner != render::InnerLayers::kHidden ? 0.35f : any ? 0.45f : 1.0f;
  style.coloring =
      a.color == "displacement" ? render::Coloring::kDisplacement : render::Coloring::kOrgan;
  style.springs = a.springs;
  if (a.white) style.background = {1.0f, 1.0f, 1.0f, 1.0f};
  return style;
}

}  // namespace

int run_render(const RenderArgs& a) {
  check_output(a.output, {".png"}, "picture");
  if (!(a.at_s >= 0.0) || !std::isfinite(a.at_s))
    throw invalid_input("--at", "must be a time >= 0 s");
  render::InnerLayers inner = render::InnerLayers::kHidden;
  if (a.inner == "translucent")
    inner = render::InnerLayers::kTranslucent;
  else if (a.inner == "wireframe")
    inner = render::InnerLayers::kWireframe;
  else if (a.inner != "hidden")
    throw invalid_input("--inner",
                        "expected hidden, translucent or wireframe, got '" + a.inner + "'");
  if (a.color != "organ" && a.color != "displacement")
    throw invalid_input("--color", "expected organ or displacement, got '" + a.color + "'");
  if (a.display_skin != "on" && a.display_skin != "off")
    throw invalid_input("--display-skin", "expected on or off, got '" + a.display_skin + "'");
  if (a.structures.empty()) throw invalid_input("--structures", "expected all, none or names");
  const CameraOption view = parse_camera(a.camera);  // checked before the (slow) model

  // The context first: with no EGL, say so before spending seconds on a model.
  render::HeadlessContext context;
  render::Renderer renderer;

  const io::ReadyScene p =
      prepare(a.what, stderr_progress(a.verbose), /*paper=*/false, /*cuts=*/true);
  sim::Simulation s = io::make_scene_simulation(p);
  interact::ToolDriver driver = io::make_tool_driver(p.scene, /*warn_scalpels=*/false);
  // A scene's scalpels cut as the run's do: the picture is of the model they leave.
  std::shared_ptr<const Model> model = p.model;
  interact::ScalpelDriver scalpels =
      interact::make_scalpel_driver(p.scene.scalpels, *model, p.scene.source);
  while (s.time_s < a.at_s - 1e-9 * std::max(1.0, a.at_s)) {
    if (!scalpels.scalpels.empty()) interact::advance_scalpels(scalpels, model, s, driver);
    interact::apply_tools(s, driver);
    sim::step(s);
  }
  const Model& m = *model;

  render::Frame frame;
  frame.model = &m;
  frame.x = &s.x;
  frame.style = render_style(a, m, inner);

  int acting = 0;
  for (size_t t = 0; t < driver.tools.size(); ++t) {
    if (t >= driver.active.size() || !driver.active[t]) continue;
    if (driver.tools[t].grasp) {  // a grasper: marked where its jaws hold the skin
      for (int32_t node : driver.grasps[t].nodes) render::add_contact_marker(frame, node);
      ++acting;
      continue;
    }
    const int32_t node = driver.routes[t].contact_node;
    ++acting;
    render::add_force_arrow(frame, node, driver.tools[t].force_mn, 60.0);  // 60 mm per N
    render::add_contact_marker(frame, node);
    if (a.rings) frame.rings.push_back({node, p.scene.routing.locality});
  }
  render::Camera camera = render::fit_camera(m, view.azimuth_deg, view.elevation_deg);
  if (view.distance_mm > 0.0) camera.distance_mm = view.distance_mm;
  const std::vector<render::LegendEntry> legend =
      a.legend ? render::legend_entries(frame) : std::vector<render::LegendEntry>{};
  render::write_png(render::render_image(
                        [&](int w, int h) {
                          renderer.draw(frame, camera, w, h);
                          render::draw_legend(legend, w, h);
                        },
                        a.size[0], a.size[1]),
                    a.output);
  std::cout << fmt::format("lamina render: wrote {} ({}x{}, t = {:.3g} s, {} tool(s) acting)\n",
                           a.output, a.size[0], a.size[1], s.time_s, acting);
  return 0;
}

}  // namespace lamina::cli
