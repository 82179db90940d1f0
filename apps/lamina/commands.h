#pragma once
/// \file
/// The CLI's subcommands, as plain functions of parsed options (main.cpp does the parsing).

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/build_model.h"
#include "lamina/net/serve.h"

namespace lamina::cli {

/// Progress for long work on stderr: an in-place line on a terminal; on a pipe or file, one line
/// per stage when `verbose`, nothing otherwise.
ProgressFn stderr_progress(bool verbose);

/// Checks an output file path before any long work (so a typo does not cost a whole build): the
/// extension is one of `extensions` and the folder exists. Throws lamina::Error.
void check_output(const std::string& path, const std::vector<std::string>& extensions,
                  const char* what);
/// An output folder must exist already, or be creatable inside a writable one.
void check_output_folder(const std::string& dir);
/// Creates `dir` (and its parents) or throws lamina::Error (kOutput).
void create_folder(const std::filesystem::path& dir);

/// The segmentation named by `input`: the built-in phantom for "phantom", else a file or folder.
/// How every command reads a volume (here and in io::make_scene_model): main() sets the voxel
/// budget (--max-voxels).
extern io::ReadVolumeOptions volume_read_options;
LabelVolume read_input(const std::string& input);

struct PhantomArgs {
  std::string output;
  geometry::PhantomOptions options;
};
int run_phantom(const PhantomArgs& args);

struct BuildArgs {
  std::string input = io::kScenePhantom;
  std::string output;
  bool json = false;
  bool quiet = false;
  bool verbose = false;
  std::vector<int32_t> labels;           ///< --label: one, or several (their union)
  std::vector<std::string> embed;        ///< --embed LABEL[=NAME] entries
  std::vector<std::string> embed_masks;  ///< --embed-mask FILE[=NAME] entries
  std::vector<std::string> organs;       ///< --organ LABEL=NAME entries: a model per organ
  std::vector<std::string> organ_masks;  ///< --organ-mask FILE=NAME entries
  model::BuildOptions options;
};
int run_build(const BuildArgs& args);
/// `lamina build --organ/--organ-mask`: a model per organ and a world scene in the folder
/// args.output (organs_command.cpp); run_build() hands such a build here.
int run_build_organs(const BuildArgs& args);
/// --label, --embed and --embed-mask of `args` in its build options (the masks read).
model::BuildOptions with_structures(const BuildArgs& args);

struct InfoArgs {
  std::string model;
  bool json = false;
};
int run_info(const InfoArgs& args);

struct ExportArgs {
  std::string model;
  std::string output;
  int layer = 0;
};
int run_export(const ExportArgs& args);

struct RunArgs {
  std::string scene;   ///< scene file; empty = the default scene (the physical liver, poked)
  bool paper = false;  ///< no scene file: the reference paper's setup (io::paper_scene())
  std::string output;  ///< output folder, created if missing
  bool json = false;
  bool quiet = false;
  bool verbose = false;
  bool realtime = false;  ///< pace the steps at rate_hz of wall time
  double rate_hz = 1000.0;
  int64_t checkpoint_every = 0;  ///< > 0: write OUTDIR/checkpoint.lmck every this many steps
  std::string resume;            ///< a checkpoint to continue from
  int64_t stop_after_steps = 0;  ///< > 0: stop (with a checkpoint) after this many steps
};
/// Simulates a scene: writes OUTDIR/metrics.csv, summary.json, skin.pvd and frames/ (layout in
/// docs/scenes.md).
int run_run(const RunArgs& args);
/// `lamina run` on a world scene (io::is_world_scene_file()): several bodies in one world;
/// run_run() hands such a scene here.
int run_world(const RunArgs& args);

struct ViewArgs {
  std::string what = io::kScenePhantom;  ///< model, input or scene
  bool paper = false;                    ///< the reference paper's model and constants
  std::string script;                    ///< scripted input (docs/viewer.md)
  std::string report;                    ///< JSON report written at exit
  double rate_hz = 1000.0;
  bool auto_rate = false;  ///< no --rate: the highest rate the machine keeps (rate_choice.h)
  double gain_n_per_mm = 0.01;
  std::array<int, 2> size = {1400, 900};
  bool verbose = false;
};
/// Opens the interactive viewer.
int run_view(const ViewArgs& args);

struct RenderArgs {
  std::string what = io::kScenePhantom;  ///< model, input or scene
  std::string output;                    ///< PNG
  double at_s = 0.0;                     ///< simulate the scene up to this time first
  std::array<int, 2> size = {1200, 900};
  std::string camera;            ///< "AZ,EL[,DIST]" degrees, degrees, mm
  std::string inner = "hidden";  ///< hidden, translucent, wireframe
  std::string color = "organ";   ///< organ, displacement
  bool springs = false;
  bool rings = false;               ///< colour the contacts' BFS rings (paper fig. 2)
  bool white = false;               ///< white background (print)
  std::string display_skin = "on";  ///< on: the model's display skin in place of layer 0; off
  std::string structures = "all";   ///< embedded structures shown: all, none or NAME[,NAME...]
  bool legend = false;              ///< the organ and each structure shown, named in its colour
  bool verbose = false;
};
/// Renders one picture without a window (EGL surfaceless).
int run_render(const RenderArgs& args);

struct FiguresArgs {
  std::string output;                     ///< folder
  std::string input = io::kScenePhantom;  ///< mask file, DICOM folder or "phantom"
  bool quick = false;                     ///< fewer localities and shorter runs (CI)
  bool verbose = false;
};
/// The reference paper's figures 4-6 and a volume-change plot, on any organ.
int run_figures(const FiguresArgs& args);

struct ValidateArgs {
  std::string what = io::kScenePhantom;  ///< SCENE.json, a mask file or folder, or "phantom"
  std::string output;                    ///< folder for CSV, plots and summary; empty = none
  bool json = false;                     ///< the summary as JSON on stdout
  bool quick = false;                    ///< one depth (10%) instead of four (CI)
  std::vector<double> depths;  ///< indentation depths, % of the organ's depth; empty = default
  bool deepest = false;  ///< indent where the organ is deepest, not at its most anterior point
  /// The indenter's radius, mm; 0: 1.6 spring lengths, at least 8 mm (so it follows the mesh; a
  /// study across resolutions fixes it)
  double indenter_radius_mm = 0.0;
  bool tool_only = false;  ///< only the tool case (the sphere tip against FEM pressed alike)
  /// only the scene's own model against corotational and linear FEM (Neo-Hookean FEM for a
  /// Neo-Hookean model): no other structure, no tool case
  bool model_only = false;
  /// The tool case's sphere: pressure per mm of penetration, kPa/mm; 0: 10 E / radius
  double sphere_stiffness_kpa_per_mm = 0.0;
  bool stability = false;  ///< the stability suite instead of the finite-element comparison
  /// With stability: only the cases whose name contains one of these (e.g. "3 tools"); empty = all
  std::vector<std::string> cases;
  /// Diagnostic: the finite elements on the model's own tetrahedra instead of an independent
  /// mesh (separates the model's error from the discretisation's).
  bool fem_on_model = false;
  /// The dent as the mesh is refined: the organ built at these skin sizes (two or more), each
  /// pressed by the same held push (refinement_report.h); empty = the comparison
  std::vector<int32_t> refine;
  bool verbose = false;
};
/// The mass-spring model against linear and corotational finite elements on the same
/// indentations (docs/validation.md).
int run_validate(const ValidateArgs& args);

struct SoakArgs {
  std::string
      scene;  ///< model, material and solver (its tools are ignored); empty = physical phantom
  std::string output;
  int64_t steps = 1000000;
  uint64_t seed = 1;
  int32_t cuts = 0;  ///< random cuts spread over the run (each one kind in turn)
  bool json = false;
  bool no_plot = false;
  bool verbose = false;
};
/// A long run under random tools, then release: memory flat, no NaN, volume drift bounded, back
/// at rest (docs/testing.md). Exit 1 if any check fails.
int run_soak(const SoakArgs& args);

struct ResectArgs {
  std::string input = io::kScenePhantom;  ///< segmentation; "phantom": its carved-out anatomy
  std::string plane;                      ///< "X,Y,Z:NX,NY,NZ" (mm, LPS)
  std::string surface;                    ///< or a surface or markups file
  std::string keep;                       ///< "X,Y,Z": the remnant holds it; empty/"larger"
  double margin_mm = 10.0;
  std::string liver = "normal";    ///< normal, chemotherapy, cirrhosis
  std::vector<int32_t> labels;     ///< the organ's labels (--label)
  std::vector<std::string> embed;  ///< LABEL[=NAME]: tumours by name, others crossed
  std::string output;              ///< folder: parts, surface, report.json
  std::string format = "nii.gz";   ///< the parts' label volume: nii.gz, nii or nrrd
  bool json = false;
  bool segments = false;               ///< Couinaud's segments (a first stage)
  std::string segments_from = "auto";  ///< what places them: auto, vessels, atlas
};
/// Plans a resection: volumes, future liver remnant, tumour margins, structures crossed
/// (docs/resection.md).
int run_resect(const ResectArgs& args);

/// `lamina serve`'s options: the library's serve options (include/lamina/net/serve.h, named
/// as the command line spells them) and what to serve.
struct ServeArgs : net::ServeOptions {
  std::string what = io::kScenePhantom;  ///< model, input or scene, as `lamina view` takes it
  bool paper = false;                    ///< the reference paper's model and constants
  bool verbose = false;
};
/// Runs the simulation as an OpenIGTLink server (docs/openigtlink.md): tool poses in, the
/// deformed skin and the reaction force out, in real time, until --duration or Ctrl-C.
int run_serve(const ServeArgs& args);

struct BenchArgs {
  bool json = false;
  bool quick = false;  ///< paper-size and 10k models only, shorter timings (under a minute)
  bool verbose = false;
  /// only these physical-liver cases (names as `lamina bench` prints them, without
  /// "physical_"), nothing else
  std::vector<std::string> physical;
};
/// Measures this machine: memory bandwidth, then build time, explicit and implicit step time and
/// time from a poke to rest on phantom models of about 2k, 10k and 100k nodes.
int run_bench(const BenchArgs& args);

}  // namespace lamina::cli
