// `lamina`: one command-line tool with subcommands (phantom, build, info, export, run, view,
// render, figures, serve, ...).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"

namespace {

using namespace lamina;

// "1.5" -> {1.5, 1.5, 1.5}; "0.6,0.6,1.6" -> per axis.
std::array<double, 3> parse_spacing(const std::string& s) {
  std::array<double, 3> v{};
  double a, b, c;
  char tail;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &a, &b, &c, &tail) == 3) return {a, b, c};
  if (std::sscanf(s.c_str(), "%lf%c", &a, &tail) == 1) return {a, a, a};
  throw lamina::invalid_input("--spacing", "expected MM or X,Y,Z in mm, got '" + s + "'");
  return v;
}

std::array<int64_t, 3> parse_size(const std::string& s) {
  long long a, b, c;
  char tail;
  if (std::sscanf(s.c_str(), "%lld,%lld,%lld%c", &a, &b, &c, &tail) == 3 && a > 1 && b > 1 && c > 1)
    return {a, b, c};
  throw lamina::invalid_input("--size", "expected NX,NY,NZ voxels (each > 1), got '" + s + "'");
}

// "1200x900" -> {1200, 900}
std::array<int, 2> parse_image_size(const std::string& s, const char* option) {
  int w = 0, h = 0;
  char tail;
  if (std::sscanf(s.c_str(), "%dx%d%c", &w, &h, &tail) == 2 && w >= 16 && h >= 16 && w <= 8192 &&
      h <= 8192)
    return {w, h};
  throw lamina::invalid_input(option,
                              "expected WIDTHxHEIGHT in pixels (16..8192), got '" + s + "'");
}

// One subcommand of `lamina`: its options registered on the app, bound to what it parses into
// (held by `run`, so that they outlive the registration), and what runs it once parsed, with the
// verbosity -q/-v chose (0, 1, 2).
struct Subcommand {
  CLI::App* app = nullptr;
  std::function<int(int verbosity)> run;
};

// `lamina phantom`: the built-in phantom written as a mask.
Subcommand add_phantom(CLI::App& app) {
  struct Parsed {
    cli::PhantomArgs phantom;
    std::string spacing = "1.5", size;
  };
  auto l = std::make_shared<Parsed>();
  auto& phantom = l->phantom;
  auto& spacing = l->spacing;
  auto& size = l->size;
  auto* ph = app.add_subcommand("phantom", "write the built-in liver-like phantom mask (NIfTI)");
  ph->add_option("-o,--output", phantom.output, "output image (.nii.gz, .nii, .nrrd, .mha)")
      ->required();
  ph->add_option("--spacing", spacing, "voxel size in mm: MM or X,Y,Z (default 1.5)");
  ph->add_option("--size", size, "grid size in voxels NX,NY,NZ (default: fits the organ)");
  ph->add_flag("--labels", phantom.options.anatomy,
               "also the anatomy inside, a label each: 1 liver, 2 vessel tree (entering at the "
               "hilum), 3 tumour; the organ is their union");
  ph->add_flag("--carved-out", phantom.options.carved_out,
               "the anatomy as most labelmaps store it (implies --labels): 1 liver parenchyma "
               "only, 2 portal vein (its trunk leaving the organ), 3 tumour, 4 hepatic veins, "
               "5 inferior vena cava (mostly outside the organ); build it with --label 1 --embed");
  ph->add_flag("--wrapped", phantom.options.wrapped,
               "the vena cava wrapped by the liver (a bridge of caudate tissue behind it): with "
               "--carved-out the vena cava, the hepatic veins draining into it and the right "
               "one reaching the lateral surface are tunnels through label 1, and the lesion "
               "bulges 12 mm out; alone, the same organ's whole mask");
  return {ph, [l](int) {
            l->phantom.options.spacing_mm = parse_spacing(l->spacing);
            if (!l->size.empty()) l->phantom.options.size = parse_size(l->size);
            return cli::run_phantom(l->phantom);
          }};
}

// `lamina build`: a model (or one per organ) from a segmentation.
Subcommand add_build(CLI::App& app) {
  struct Parsed {
    cli::BuildArgs build;
    double density_g_cm3 = 1.06;
  };
  auto l = std::make_shared<Parsed>();
  auto& build = l->build;
  auto& density_g_cm3 = l->density_g_cm3;
  auto& bo = build.options;
  auto* bu =
      app.add_subcommand("build", "build a multi-layer mass-spring model from a segmentation");
  bu->add_option(
      "input", build.input,
      "NIfTI/NRRD/MetaImage file or DICOM folder; 'phantom' (default) = built-in phantom");
  bu->add_option("-o,--output", build.output,
                 "model file to write (.vtu, opens in ParaView); a folder with --organ")
      ->required();
  bu->add_option("--layers", bo.layers, "number of layers S, skin included (default 2)");
  bu->add_option("--skin-vertices", bo.skin_vertices, "target skin vertex count (default 1284)");
  bu->add_option("--layer-depth", bo.layer_depth_mm, "depth between layers in mm (default: auto)");
  bu->add_option("--label", build.labels,
                 "label(s) to model, e.g. 1 or 1,5: the organ is their union (default: any "
                 "non-zero voxel)")
      ->delimiter(',');
  bu->add_option("--display-triangles", bo.display_triangles,
                 "triangles of the display skin drawn instead of the simulation's skin, carried "
                 "by the tetrahedra; 0 = none (default 100000)");
  bu->add_option("--embed", build.embed,
                 "structures inside the organ from labels of the same segmentation, carried by "
                 "the tetrahedra: LABEL[=NAME],... e.g. 2=vessels,3=tumour")
      ->delimiter(',');
  bu->add_option("--embed-mask", build.embed_masks,
                 "a structure from a separate mask on the segmentation's grid: FILE[=NAME] "
                 "(repeatable)");
  bu->add_option("--organ", build.organs,
                 "several organs of the segmentation, each a model of its own: LABEL=NAME,... "
                 "e.g. 1=liver,4=gallbladder; -o is then a folder, with a model per organ and "
                 "scene.json, a world scene of them (docs/world.md)")
      ->delimiter(',');
  bu->add_option("--organ-mask", build.organ_masks,
                 "an organ from a separate mask on the segmentation's grid: FILE=NAME "
                 "(repeatable; with or without --organ)");
  bu->add_option("--structure-triangles", bo.structure_triangles,
                 "triangles of each embedded structure's surface (default 20000)");
  bu->add_option("--locality", bo.locality, "BFS rings precomputed per node (default 4)");
  bu->add_option("--structure", bo.structure,
                 "what fills the organ between the layers: tets (default; tetrahedra whose edges "
                 "are the springs) or links (the paper's: nearest-node links between layers)")
      ->transform(
          CLI::CheckedTransformer(
              std::map<std::string, model::Structure>{{"tets", model::Structure::kTetrahedra},
                                                      {"links", model::Structure::kLinks}},
              CLI::ignore_case)
              .description("{tets,links}"));  // not the enum's bytes (uint8_t prints as a char)
  bu->add_option(
      "--links", bo.inter_layer_links,
      "with --structure links: nearest nodes linked on each neighbour layer (default 3)");
  bu->add_option("--density", density_g_cm3, "tissue density in g/cm^3 (default 1.06, liver)");
  bu->add_option("--stiffness", bo.stiffness_n_per_m, "spring stiffness in N/m (default 3)");
  bu->add_flag("--json", build.json, "print the summary as one JSON object on stdout");
  return {bu, [l](int verbosity) {
            l->build.options.density_kg_per_mm3 = l->density_g_cm3 * 1e-6;  // g/cm^3 -> kg/mm^3
            l->build.quiet = verbosity == 0;
            l->build.verbose = verbosity == 2;
            return cli::run_build(l->build);
          }};
}

// `lamina info`: a saved model summarised.
Subcommand add_info(CLI::App& app) {
  struct Parsed {
    cli::InfoArgs info;
  };
  auto l = std::make_shared<Parsed>();
  auto& info = l->info;
  auto* in = app.add_subcommand("info", "summarise a saved model");
  in->add_option("model", info.model, "model file (.vtu)")->required();
  in->add_flag("--json", info.json, "print the summary as one JSON object on stdout");
  return {in, [l](int) { return cli::run_info(l->info); }};
}

// `lamina export`: one layer of a model as a mesh.
Subcommand add_export(CLI::App& app) {
  struct Parsed {
    cli::ExportArgs exp;
  };
  auto l = std::make_shared<Parsed>();
  auto& exp = l->exp;
  auto* ex = app.add_subcommand("export", "write one layer of a model as a mesh");
  ex->add_option("model", exp.model, "model file (.vtu)")->required();
  ex->add_option("-o,--output", exp.output, "mesh file (.obj, .ply, .vtp, .stl)")->required();
  ex->add_option("--layer", exp.layer, "layer index, 0 = skin (default 0)");
  return {ex, [l](int) { return cli::run_export(l->exp); }};
}

// `lamina run`: a scene simulated to files.
Subcommand add_run(CLI::App& app) {
  struct Parsed {
    cli::RunArgs run;
  };
  auto l = std::make_shared<Parsed>();
  auto& run = l->run;
  auto* ru = app.add_subcommand("run", "simulate a scene: tools push the organ, it responds");
  ru->add_option("scene", run.scene,
                 "scene file (.json, docs/scenes.md); default: the physical liver (tetrahedra, "
                 "E = 6 kPa, nu = 0.45, 1 ms steps) poked on the phantom");
  ru->add_flag("--paper", run.paper,
               "no scene file: the reference paper's setup instead (layers and links, K = 3 N/m, "
               "gamma = 3 kg/s, unit masses, semi-implicit Euler at 10 ms)");
  ru->add_option(
        "-o,--output", run.output,
        "output folder (created): metrics.csv, summary.json, skin.pvd, a .pvd per embedded "
        "surface (display_skin.pvd, vessels.pvd, ...), frames/")
      ->required();
  ru->add_flag("--json", run.json, "also print the summary as one JSON object on stdout");
  ru->add_flag("--realtime", run.realtime,
               "pace the steps at --rate per wall second (a haptic loop); reports jitter");
  ru->add_option("--rate", run.rate_hz, "steps per wall second with --realtime (default 1000)");
  ru->add_option("--checkpoint-every", run.checkpoint_every,
                 "save the whole state to OUTDIR/checkpoint.lmck every N steps (atomically)");
  ru->add_option("--resume", run.resume,
                 "continue a run from its checkpoint, bit for bit (the scene defaults to the "
                 "checkpoint's)");
  ru->add_option("--stop-after", run.stop_after_steps,
                 "stop after N steps with a checkpoint (run a long job in chunks)");
  return {ru, [l](int verbosity) {
            l->run.quiet = verbosity == 0;
            l->run.verbose = verbosity == 2;
            return cli::run_run(l->run);
          }};
}

// `lamina view`: the interactive viewer.
Subcommand add_view(CLI::App& app) {
  struct Parsed {
    cli::ViewArgs view;
    std::string view_size = "1400x900";
  };
  auto l = std::make_shared<Parsed>();
  auto& view = l->view;
  auto& view_size = l->view_size;
  auto* vi = app.add_subcommand(
      "view", "open the interactive viewer: drag the organ with the mouse, tune every parameter");
  vi->add_option("input", view.what,
                 "model (.vtu), segmentation, DICOM folder, scene (.json) or 'phantom' (default)");
  vi->add_flag("--paper", view.paper,
               "the reference paper's model and constants instead of the physical liver");
  CLI::Option* view_rate = vi->add_option(
      "--rate", view.rate_hz,
      "simulation steps per wall second, each 1/rate s of simulated time (real time; default: "
      "the highest of 1000, 500, 250, 120, 60 the machine keeps, chosen as it runs; 0 = as fast "
      "as possible at the scene's dt)");
  vi->add_option("--size", view_size, "window size WxH (default 1400x900)");
  vi->add_option("--gain", view.gain_n_per_mm,
                 "drag force per mm of mouse drag, N/mm (default 0.01)");
  vi->add_option("--script", view.script,
                 "scripted input: timed mouse/key events (docs/viewer.md)");
  vi->add_option("--report", view.report, "write a JSON report here when the window closes");
  return {vi, [l, view_rate](int verbosity) {
            l->view.size = parse_image_size(l->view_size, "--size");
            l->view.verbose = verbosity == 2;
            l->view.auto_rate = view_rate->count() == 0;
            return cli::run_view(l->view);
          }};
}

// `lamina render`: a picture without a window.
Subcommand add_render(CLI::App& app) {
  struct Parsed {
    cli::RenderArgs rend;
    std::string render_size = "1200x900";
  };
  auto l = std::make_shared<Parsed>();
  auto& rend = l->rend;
  auto& render_size = l->render_size;
  auto* re = app.add_subcommand("render", "render a picture without a window (no display needed)");
  re->add_option("input", rend.what,
                 "model (.vtu), segmentation, DICOM folder, scene (.json) or 'phantom' (default)");
  re->add_option("-o,--output", rend.output, "PNG to write")->required();
  re->add_option("--at", rend.at_s, "simulate the scene's tools up to this time, s (default 0)");
  re->add_option("--size", render_size, "image size WxH (default 1200x900)");
  re->add_option("--camera", rend.camera,
                 "AZ,EL[,DIST]: degrees from the anterior view, degrees up, mm (default -30,20)");
  re->add_option("--inner", rend.inner, "inner layers: hidden (default), translucent, wireframe");
  re->add_option("--color", rend.color, "skin colour: organ (default) or displacement");
  re->add_flag("--springs", rend.springs, "draw every spring");
  re->add_flag("--rings", rend.rings, "colour each contact's BFS rings (the paper's figure 2)");
  re->add_flag("--white", rend.white, "white background (for print)");
  re->add_option("--display-skin", rend.display_skin,
                 "on (default): draw the model's fine display skin, if it has one, in place of "
                 "the simulation's skin; off: the simulation's skin");
  re->add_option("--structures", rend.structures,
                 "embedded structures to draw inside a translucent skin: all (default), none, or "
                 "names (vessels,tumour)");
  re->add_flag("--legend", rend.legend,
               "name the organ and each structure drawn, in its colour (top right)");
  return {re, [l](int verbosity) {
            l->rend.size = parse_image_size(l->render_size, "--size");
            l->rend.verbose = verbosity == 2;
            return cli::run_render(l->rend);
          }};
}

// `lamina figures`: the reference paper's figures.
Subcommand add_figures(CLI::App& app) {
  struct Parsed {
    cli::FiguresArgs figs;
  };
  auto l = std::make_shared<Parsed>();
  auto& figs = l->figs;
  auto* fi = app.add_subcommand(
      "figures", "reproduce the reference paper's figures 4-6 and a volume plot on any organ");
  fi->add_option("-o,--output", figs.output, "output folder (created)")->required();
  fi->add_option("--input", figs.input,
                 "segmentation or DICOM folder (default: the built-in phantom)");
  fi->add_flag("--quick", figs.quick, "shorter runs and fewer localities (a CI smoke run)");
  return {fi, [l](int verbosity) {
            l->figs.verbose = verbosity == 2;
            return cli::run_figures(l->figs);
          }};
}

// `lamina soak`: a long run under random tools.
Subcommand add_soak(CLI::App& app) {
  struct Parsed {
    cli::SoakArgs soak;
  };
  auto l = std::make_shared<Parsed>();
  auto& soak = l->soak;
  auto* so = app.add_subcommand(
      "soak", "a long run under random tools: memory flat, no NaN, volume kept, back to rest");
  so->add_option("scene", soak.scene,
                 "scene for the model, material and solver (default: a physical phantom liver)");
  so->add_option("-o,--output", soak.output, "output folder: soak.csv, summary.json, soak.png")
      ->required();
  so->add_option("--steps", soak.steps, "steps to run (default 1000000)");
  so->add_option("--seed", soak.seed, "random seed for the tools (default 1)");
  so->add_option("--cuts", soak.cuts,
                 "random cuts spread over the run, in turn through nodes, along a skin edge, "
                 "the same blade again and grazing the skin (default 0)")
      ->check(CLI::NonNegativeNumber);
  so->add_flag("--json", soak.json, "print the summary as JSON on stdout");
  so->add_flag("--no-plot", soak.no_plot, "skip soak.png (no gnuplot needed)");
  return {so, [l](int verbosity) {
            l->soak.verbose = verbosity == 2;
            return cli::run_soak(l->soak);
          }};
}

// `lamina serve`: the OpenIGTLink (and web) server.
Subcommand add_serve(CLI::App& app) {
  struct Parsed {
    cli::ServeArgs serve;
  };
  auto l = std::make_shared<Parsed>();
  auto& serve = l->serve;
  auto* se = app.add_subcommand(
      "serve",
      "run the simulation as an OpenIGTLink server for 3D Slicer: tool poses in, the deformed "
      "skin and the reaction force out (docs/openigtlink.md)");
  se->add_option("input", serve.what,
                 "model (.vtu), segmentation, DICOM folder, scene (.json) or 'phantom' (default)");
  se->add_flag("--paper", serve.paper,
               "the reference paper's model and constants instead of the physical liver");
  se->add_option("--host", serve.host,
                 "address to listen on (default 127.0.0.1; 0.0.0.0 = every interface)");
  se->add_option("--port", serve.port, "TCP port (default 18944; 0 = any free one, logged)");
  se->add_option("--send-hz", serve.send_hz,
                 "POLYDATA messages per second to every client (default 30; 0 = only in answer "
                 "to GET_POLYDATA)");
  se->add_option("--embedded-hz", serve.embedded_hz,
                 "POLYDATA messages per second of each embedded surface, named as in the model "
                 "(display_skin, vessels, ...) (default 10; 0 = only in answer to GET_POLYDATA)");
  se->add_option("--reaction-hz", serve.reaction_hz,
                 "reaction-force messages per second, at most one per step (default 1000: every "
                 "step at 1 kHz; 0 = one with each POLYDATA batch)");
  se->add_flag("--all-layers", serve.all_layers,
               "stream every layer (LaminaLayer1, ...), not only the skin (LaminaSkin)");
  CLI::Option* serve_rate = se->add_option(
      "--rate", serve.rate_hz,
      "simulation steps per wall second, each 1/rate s of simulated time (default: the highest "
      "of 1000, 500, 250, 120, 60 the machine keeps, unless a client asks with a STRING "
      "'LaminaRate')");
  se->add_option("--duration", serve.duration_s,
                 "stop after this many seconds of wall time (default: run until Ctrl-C)");
  se->add_option("--frame", serve.frame,
                 "coordinates on the wire: ras (default, 3D Slicer's) or lps (the model's own)");
  se->add_option("--tool-device", serve.tool_device,
                 "only TRANSFORM/POSITION messages of this device name move the tool (default: "
                 "any)");
  se->add_option("--grasper-device", serve.grasper_device,
                 "TRANSFORM/POSITION messages of this device name move a grasper, whose jaws "
                 "close on the skin at the first and hold it; any message named NAME + \"Open\" "
                 "opens them (default LaminaGrasper)");
  se->add_option("--grasper-radius", serve.grasper_radius_mm,
                 "skin within this distance of the grasper's jaws is held, mm (default 4)")
      ->check(CLI::PositiveNumber);
  se->add_option("--scalpel-device", serve.scalpel_device,
                 "TRANSFORM/POSITION messages of this device name are a scalpel's: the path its "
                 "tip traces (its z axis the blade's, towards the tip) cuts the organ when a "
                 "message of this name + 'Up' comes, the poses pause or the client goes; this "
                 "name + 'Undo' takes the last cut back (default LaminaScalpel; '' for none)");
  se->add_option("--scalpel-depth", serve.scalpel_depth_mm,
                 "the scalpel blade's cutting length behind its tip, mm (default 20)");
  se->add_option("--scalpel-pause", serve.scalpel_pause_s,
                 "a scalpel stroke whose poses stop this long cuts, s (default 0.25)");
  se->add_option("--tip-radius", serve.tip_radius_mm, "tool tip sphere radius, mm (default 5)");
  se->add_option("--tip-stiffness", serve.tip_stiffness_n_per_m,
                 "the virtual coupling between the device and the tool's proxy on the skin "
                 "(or the paper's push per mm inside), N/m = mN/mm (default 20)");
  se->add_option("--max-force", serve.max_force_n,
                 "the reaction sent back never exceeds this, N (default 3)");
  se->add_option("--max-message-mb", serve.max_message_mb,
                 "a client sending a larger message is dropped, MB (default 4)");
  se->add_option("--stall-timeout", serve.stall_timeout_s,
                 "a client silent this long in the middle of a message is dropped, s (default 5)");
  se->add_option("--max-clients", serve.max_clients, "connections served at once (default 16)");
  se->add_option("--threads", serve.threads,
                 "threads per simulation step (default: OpenMP's; 1 on a machine shared with "
                 "other busy programs)");
  se->add_flag("--web", serve.web,
               "also serve the page for a browser or a headset (WebXR) and its stream "
               "(docs/web.md); the address with its token is logged");
  se->add_option("--listen", serve.web_host,
                 "the web server's address (default 127.0.0.1: this machine only; 0.0.0.0: "
                 "every interface)");
  se->add_option("--web-port", serve.web_port, "the web server's port (default 8765; 0 = any)");
  se->add_option("--web-hz", serve.web_hz, "frames per second to each page (default 60)");
  se->add_option("--token", serve.web_token,
                 "the token the page's address needs (default: a random one)");
  se->add_option("--web-root", serve.web_root,
                 "the page's files (default: the build's web/ beside the lamina binary)");
  se->add_flag("--self-signed", serve.self_signed,
               "the web server speaks TLS (https, wss) with a certificate made for the session; "
               "its fingerprint is logged (a headset off this machine needs TLS for WebXR)");
  se->add_option("--cert", serve.cert, "the web server speaks TLS with this PEM certificate");
  se->add_option("--key", serve.key, "... and this PEM private key");
  se->add_option("--gain", serve.gain_n_per_mm,
                 "a page's mouse drag: force per mm dragged, N/mm (default 0.01)");
  return {se, [l, serve_rate](int verbosity) {
            l->serve.verbose = verbosity == 2;
            l->serve.auto_rate = serve_rate->count() == 0;
            return cli::run_serve(l->serve);
          }};
}

// `lamina bench`: this machine's measurements.
Subcommand add_bench(CLI::App& app) {
  struct Parsed {
    cli::BenchArgs bench;
  };
  auto l = std::make_shared<Parsed>();
  auto& bench = l->bench;
  auto* be = app.add_subcommand("bench",
                                "measure this machine: step times, poke to rest, bandwidth floor");
  be->add_flag("--json", bench.json, "print one JSON object (keys: docs/benchmarks.md)");
  be->add_flag("--quick", bench.quick, "paper-size and 10k-node models only (under a minute)");
  be->add_option(
        "--physical", bench.physical,
        "only these cases of the physical liver, comma-separated: paper, paper_neo_hookean, 5k, "
        "5k_neo_hookean, paper_10ms_jacobi, paper_10ms_multigrid, 20k_10ms_jacobi, "
        "20k_10ms_multigrid, 20k_10ms_neo_hookean, 43k_10ms_jacobi, 43k_10ms_multigrid, 43k, "
        "paper_16ms_multigrid, 20k_16ms_multigrid, "
        "43k_neo_hookean, 100k, 100k_haptic_tip, 100k_neo_hookean")
      ->delimiter(',');
  return {be, [l](int verbosity) {
            l->bench.verbose = verbosity == 2;
            return cli::run_bench(l->bench);
          }};
}

// `lamina validate`: the model against finite elements, and the stability suite.
Subcommand add_validate(CLI::App& app) {
  struct Parsed {
    cli::ValidateArgs val;
  };
  auto l = std::make_shared<Parsed>();
  auto& val = l->val;
  auto* va = app.add_subcommand(
      "validate",
      "check the mass-spring model against linear and corotational finite elements on the same "
      "indentations (docs/validation.md)");
  va->add_option("input", val.what,
                 "scene (.json), segmentation or DICOM folder (default: the built-in phantom)");
  va->add_option("-o,--output", val.output,
                 "folder (created): validation.csv, summary.json, plots");
  va->add_flag("--json", val.json, "print the summary as one JSON object on stdout");
  va->add_flag("--quick", val.quick,
               "one depth (10%) instead of four; with --stability, 5 cases instead of 25");
  va->add_option("--depths", val.depths,
                 "indentation depths, % of the organ's depth, comma-separated (default 5,10,20,30)")
      ->delimiter(',')
      ->check(CLI::Range(0.5, 60.0));
  va->add_flag("--fem-on-model", val.fem_on_model,
               "diagnostic: solve the finite elements on the model's own tetrahedra instead of an "
               "independent mesh (the model's error without the meshes' difference)");
  va->add_flag("--deepest", val.deepest,
               "indent where the organ is deepest along +y instead of at its most anterior point "
               "(the paper's, which can be a thin edge)");
  va->add_option("--indenter-radius", val.indenter_radius_mm,
                 "the indenter's radius, mm (default: 1.6 spring lengths, at least 8 mm; fix it to "
                 "compare resolutions)")
      ->check(CLI::Range(1.0, 100.0));
  va->add_flag("--tool-only", val.tool_only,
               "only the tool case: the sphere tip pressing the skin through the contact code "
               "against finite elements pressed by the same sphere law");
  va->add_flag("--model-only", val.model_only,
               "only the scene's own model against corotational and linear finite elements (its "
               "own law's for Neo-Hookean tetrahedra): no other structure, no tool case; the "
               "comparison at clinical size in a third of the time");
  va->add_option("--sphere-stiffness", val.sphere_stiffness_kpa_per_mm,
                 "the tool case's contact stiffness, kPa per mm of penetration (default: "
                 "10 E / radius)")
      ->check(CLI::Range(1e-3, 1e4));
  va->add_flag("--stability", val.stability,
               "the stability suite: indentations to 50%, pulls, several tools, dt sweeps per "
               "integrator, each released and checked (finite, layer order, energy, rest)");
  va->add_option("--case", val.cases,
                 "with --stability: only the cases whose name, then integrator, contains this "
                 "(repeatable; e.g. \"3 tools\", \"indent 30%\", \"indent 30% implicit\")");
  va->add_option("--refine", val.refine,
                 "the dent as the mesh is refined: the organ built at these skin vertex counts "
                 "(comma-separated, two or more), each pressed by the same held 0.4 N push "
                 "(over --indenter-radius, default 5 mm; at the paper's point, or --deepest), "
                 "against the finest and an elastic half-space")
      ->delimiter(',')
      ->check(CLI::Range(50, 5000000));
  return {va, [l](int verbosity) {
            l->val.verbose = verbosity == 2;
            return cli::run_validate(l->val);
          }};
}

// `lamina resect`: a resection planned on a segmentation.
Subcommand add_resect(CLI::App& app) {
  struct Parsed {
    cli::ResectArgs resect;
  };
  auto l = std::make_shared<Parsed>();
  auto& resect = l->resect;
  auto* rs = app.add_subcommand(
      "resect",
      "plan a resection on a segmentation: future liver remnant, tumour margins, vessels crossed "
      "(docs/resection.md)");
  rs->add_option("input", resect.input,
                 "segmentation (NIfTI/NRRD/MetaImage/DICOM folder); 'phantom' (default) = the "
                 "built-in phantom with its carved-out anatomy");
  rs->add_option("--plane", resect.plane,
                 "the resection plane: POINT:NORMAL in mm (patient LPS), e.g. 30,0,0:1,0,0");
  rs->add_option("--surface", resect.surface,
                 "or the resection surface: 3D Slicer markups (.mrk.json: a Plane or a "
                 "ClosedCurve) or triangles (.obj, .ply, .stl, .off)");
  rs->add_option("--keep", resect.keep,
                 "the side kept: X,Y,Z (the side holding this point, mm) or 'larger' (default)");
  rs->add_option("--margin", resect.margin_mm,
                 "the margin wanted around each tumour, mm (default 10)")
      ->check(CLI::Range(0.0, 200.0));
  rs->add_option("--liver", resect.liver,
                 "the liver's condition, which sets the least remnant: normal (20%, default), "
                 "chemotherapy (30%), cirrhosis (40%)")
      ->check(CLI::IsMember({"normal", "chemotherapy", "cirrhosis"}));
  rs->add_option(
        "--label", resect.labels,
        "the organ's label(s), their union (default: every non-zero voxel; the phantom: 1)")
      ->delimiter(',');
  rs->add_option("--embed", resect.embed,
                 "structures: LABEL[=NAME],... a name saying tumour (tumour, lesion, metastasis, "
                 "HCC...) gets margins, the others (vessels, ducts) crossings")
      ->delimiter(',');
  rs->add_option("-o,--output", resect.output,
                 "folder (created): parts.nii.gz (1 remnant, 2 resected, on the input's grid), "
                 "surface.obj/.vtp, report.json");
  rs->add_option("--format", resect.format, "the parts' label volume: nii.gz (default), nii, nrrd");
  rs->add_flag("--json", resect.json, "print the report as one JSON object on stdout");
  rs->add_flag("--segments", resect.segments,
               "Couinaud's segments, written as segments.nii.gz with -o (mean Dice 0.805 with "
               "the vessels, 0.798 from the organ alone, against experts' labels of livers not "
               "in the atlas, docs/resection.md)");
  rs->add_option(
        "--segments-from", resect.segments_from,
        "what places the segments: vessels (the portal and hepatic veins' landmarks), "
        "atlas (expert-labelled livers like this one, bent onto its outline and, with vessels "
        "given, onto its vessels), auto (default: "
        "vessels when the two trees come as two labels, else the atlas)")
      ->check(CLI::IsMember({"auto", "vessels", "atlas"}));
  return {rs, [l](int) { return cli::run_resect(l->resect); }};
}

// Every subcommand, in the order `lamina --help` lists them.
std::vector<Subcommand> add_subcommands(CLI::App& app) {
  return {add_phantom(app), add_build(app),    add_info(app),    add_export(app), add_run(app),
          add_view(app),    add_render(app),   add_figures(app), add_soak(app),   add_serve(app),
          add_bench(app),   add_validate(app), add_resect(app)};
}

}  // namespace

namespace {

// OpenMP threads that wait at a barrier spin for GOMP_SPINCOUNT iterations (libgomp's default
// 300,000) before they sleep. One lamina alone gains nothing from the long spin, but two on a
// 2-core machine (a sweep run in parallel, ctest -j2) spin on the cores the other needs: the
// default poke took 46 s each instead of 1.7 s. A spin of 3,000 keeps the single run's time
// (1.67 s either way) and makes two at once 4.4 s (docs/architecture.md). libgomp reads the
// variable when it loads, before main, so lamina sets it and runs itself again, once; a user's
// own GOMP_SPINCOUNT or OMP_WAIT_POLICY is left alone.
void bound_openmp_spin(char** argv) {
  if (std::getenv("GOMP_SPINCOUNT") || std::getenv("OMP_WAIT_POLICY")) return;
  if (setenv("GOMP_SPINCOUNT", "3000", 0) != 0) return;
  execv("/proc/self/exe", argv);  // returns only on failure: then run with libgomp's default
}

}  // namespace

int main(int argc, char** argv) {
  bound_openmp_spin(argv);
  using namespace lamina;
  CLI::App app{"Lamina: multi-layer volumetric mass-spring models of organs from segmentations"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "lamina 0.1.0");
  int verbosity = 1;
  app.add_flag_function(
      "-q,--quiet", [&](int64_t) { verbosity = 0; }, "only warnings and errors");
  app.add_flag_function(
      "-v,--verbose", [&](int64_t) { verbosity = 2; }, "debug messages");
  app.add_option("--max-voxels", cli::volume_read_options.max_voxels,
                 "refuse a volume with more voxels than this before reading it (default 2^31; "
                 "a corrupt header can claim terabytes)")
      ->envname("LAMINA_MAX_VOXELS")
      ->check([](const std::string& v) {
        return std::strtoll(v.c_str(), nullptr, 10) > 0 ? std::string()
                                                        : "must be a positive number of voxels";
      });
  const std::vector<Subcommand> commands = add_subcommands(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : static_cast<int>(ErrorKind::kInvalidInput);
  }
  log::set_verbosity(verbosity);
  try {
    for (const Subcommand& command : commands)
      if (command.app->parsed()) return command.run(verbosity);
  } catch (const Error& e) {
    if (::isatty(2)) std::fprintf(stderr, "\r\033[K");  // clear a progress line
    std::fprintf(stderr, "lamina: error: %s\n", e.what());
    return e.exit_code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina: internal error: %s\n", e.what());
    return static_cast<int>(ErrorKind::kInternal);
  }
  return 0;
}
