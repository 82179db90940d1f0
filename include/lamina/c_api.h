/* Lamina's C API: opaque handles, status codes and a last-error message, for a game engine's
 * plugin or any language with a C foreign-function interface (docs/embedding.md).
 *
 * No C++ exception crosses it: every function that can fail returns a lamina_status, and
 * lamina_last_error() then gives the same one-line message the command-line tool prints.
 * Units as everywhere in Lamina: mm, kg, s; forces in mN (1 N = 1000 mN), stiffness in N/m.
 * Arrays of points are interleaved: x0 y0 z0 x1 y1 z1 ... (a vertex buffer's layout).
 *
 * A simulation or a world steps on the calling thread, when asked (lamina_sim_step,
 * lamina_world_step): a game engine calls it from its physics tick. Handles are not shared between
 * threads without a lock. */
#ifndef LAMINA_C_API_H
#define LAMINA_C_API_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* What a call did. The non-zero values are the command-line tool's exit codes (docs/errors.md). */
typedef enum lamina_status {
  LAMINA_OK = 0,
  LAMINA_ERROR_INTERNAL = 1,      /* a bug or an unexpected library failure */
  LAMINA_ERROR_INVALID_INPUT = 2, /* a file, scene, value or handle that cannot be used */
  LAMINA_ERROR_OUTPUT = 3,        /* a file could not be written */
  LAMINA_ERROR_UNAVAILABLE = 4,   /* something needed is missing on this machine */
  LAMINA_ERROR_UNSTABLE = 5       /* the simulation failed beyond recovery */
} lamina_status;

typedef struct lamina_model lamina_model; /* a multi-layer mass-spring model */
typedef struct lamina_sim lamina_sim;     /* a simulation of a model (owns a reference to it) */
typedef struct lamina_world lamina_world; /* several organs in contact and attached */

/* The last error on this thread, one line ("" after a success). Valid until the next call. */
const char* lamina_last_error(void);
/* "MAJOR.MINOR.PATCH" */
const char* lamina_version(void);

/* ---- models ---------------------------------------------------------------------------- */

/* Builds a model from a segmentation (a NIfTI, NRRD or MetaImage mask, a DICOM folder) or the
 * built-in phantom ("phantom"), with the default options: the reference paper's two layers and
 * 1284 skin nodes, joined by tetrahedra. Takes a few seconds. */
lamina_status lamina_model_build(const char* input, lamina_model** out);
/* Loads a model saved by `lamina build` or lamina_model_save (.vtu). */
lamina_status lamina_model_load(const char* path, lamina_model** out);
/* Saves a model (.vtu); the file is complete or not there at all. */
lamina_status lamina_model_save(const lamina_model* model, const char* path);
/* Frees a model; a simulation made from it keeps its own reference. NULL is ignored. */
void lamina_model_free(lamina_model* model);

int32_t lamina_model_node_count(const lamina_model* model);
int32_t lamina_model_layer_count(const lamina_model* model);
/* Nodes 0 .. skin_node_count - 1 are the skin (layer 0); the skin's triangles index them. */
int32_t lamina_model_skin_node_count(const lamina_model* model);
int32_t lamina_model_skin_triangle_count(const lamina_model* model);
/* Copies the skin's triangles, 3 node indices each, outward winding, into `indices`, which
 * holds `capacity` values (at least 3 * skin_triangle_count). */
lamina_status lamina_model_skin_triangles(const lamina_model* model, int32_t* indices,
                                          int64_t capacity);
/* Copies the rest positions, mm, interleaved, into `xyz` (capacity >= 3 * node_count). */
lamina_status lamina_model_rest_positions(const lamina_model* model, double* xyz, int64_t capacity);

/* ---- embedded surfaces ----------------------------------------------------------------- */

/* Surfaces carried by the model's tetrahedra (docs/model_format.md): the display skin
 * (LAMINA_ROLE_DISPLAY_SKIN: the organ's fine surface), structures inside the organ (vessels,
 * tumours, others: `lamina build --embed`), a cut's wound. Each vertex follows its tetrahedron: a
 * weighted sum of four nodes (W x). Surface k is 0 .. embedded_count - 1. */
typedef enum lamina_role {
  LAMINA_ROLE_DISPLAY_SKIN = 0,
  LAMINA_ROLE_VESSEL = 1,
  LAMINA_ROLE_TUMOUR = 2,
  LAMINA_ROLE_STRUCTURE = 3,
  LAMINA_ROLE_WOUND = 4
} lamina_role;

typedef struct lamina_embedded_info {
  const char* name;       /* "display_skin", or the structure's; valid while the model lives */
  int32_t label;          /* the segmentation label it came from (0: the organ's own skin) */
  int32_t vertex_count;   /* its vertices */
  int32_t triangle_count; /* its triangles */
  int32_t outside;        /* vertices in no tetrahedron at rest (they follow the nearest) */
  int32_t role;           /* what it is: a lamina_role; read this, not the name or the label */
} lamina_embedded_info;

int32_t lamina_model_embedded_count(const lamina_model* model);
/* LAMINA_ERROR_INVALID_INPUT for a k outside 0 .. embedded_count - 1 (as for every call below). */
lamina_status lamina_model_embedded_info(const lamina_model* model, int32_t k,
                                         lamina_embedded_info* info);
/* Copies surface k's triangles, 3 vertex indices each (0 .. vertex_count - 1), outward winding,
 * into `indices` (capacity >= 3 * triangle_count). */
lamina_status lamina_model_embedded_triangles(const lamina_model* model, int32_t k,
                                              int32_t* indices, int64_t capacity);
/* Copies surface k's rest positions, mm, interleaved (capacity >= 3 * vertex_count). */
lamina_status lamina_model_embedded_rest_positions(const lamina_model* model, int32_t k,
                                                   double* xyz, int64_t capacity);

/* ---- simulations ----------------------------------------------------------------------- */

/* Tissue parameters; lamina_material_defaults() gives the reference paper's (K = 3 N/m,
 * gamma = 3 kg/s, unit masses). young_modulus_kpa > 0 makes the tissue elastic (E, nu) through
 * the model's tetrahedra, with stiffness_n_per_m = 0 and node_mass_kg = 0 (lumped masses). */
typedef struct lamina_material {
  double stiffness_n_per_m;    /* every spring's constant, N/m; 0 = the model's */
  double damping_kg_per_s;     /* viscous damping per node, kg/s */
  double node_mass_kg;         /* every node's mass, kg; 0 = lumped from density and volume */
  double young_modulus_kpa;    /* E, kPa; 0 = off */
  double poisson_ratio;        /* nu in [0, 0.5) */
  double volume_stiffness_kpa; /* bulk modulus of the volume term between layers; 0 = off */
  int32_t tet_model;           /* a lamina_tet_model: what the tetrahedra store with E, nu */
} lamina_material;

/* The tetrahedra's elastic energy (a scene's material.model) when young_modulus_kpa is set on a
 * model with tetrahedra. */
typedef enum lamina_tet_model {
  LAMINA_TETS_SPRINGS = 0,    /* coupled springs and a volume term per tetrahedron (default) */
  LAMINA_TETS_NEO_HOOKEAN = 1 /* stable Neo-Hookean per tetrahedron (docs/physics.md) */
} lamina_tet_model;

typedef enum lamina_integrator {
  LAMINA_SEMI_IMPLICIT_EULER = 0, /* the paper's; cheap, stable only for small dt */
  LAMINA_IMPLICIT_EULER = 1,      /* backward Euler, stable at any dt */
  LAMINA_PROJECTIVE = 2           /* projective dynamics (springs and volume term only) */
} lamina_integrator;

typedef struct lamina_solver {
  int32_t integrator;         /* a lamina_integrator */
  double dt_s;                /* time step, s */
  double rest_speed_mm_per_s; /* at rest when no node moves faster */
} lamina_solver;

void lamina_material_defaults(lamina_material* material);
void lamina_solver_defaults(lamina_solver* solver);

/* A simulation of `model` at rest; NULL material or solver = the defaults. `fixed_nodes` (count
 * `fixed_count`, may be 0) are held at their rest positions: without them the organ drifts
 * away as a whole when pushed. */
lamina_status lamina_sim_create(const lamina_model* model, const lamina_material* material,
                                const lamina_solver* solver, const int32_t* fixed_nodes,
                                int32_t fixed_count, lamina_sim** out);
/* A simulation of what a scene describes (a scene .json, a .vtu model, a mask, or "phantom"):
 * its model, material, solver and boundary, as `lamina run` sets them up; the default scene's
 * physical liver for "phantom". The scene's own scripted tools are not applied: the caller's
 * tools push (lamina_sim_set_tool_tip, lamina_sim_set_forces). */
lamina_status lamina_sim_create_from_scene(const char* scene, lamina_sim** out);
void lamina_sim_free(lamina_sim* sim);

/* A spherical tool tip at `center_mm` (a game engine's instrument, a haptic device's pose). On
 * a physical tissue (a scene's default, or lamina_sim_create with E and no raw stiffness) a
 * proxy sphere follows the pose but stays outside the skin, and a virtual coupling spring of
 * `stiffness_n_per_m` (N/m = mN/mm) between proxy and pose pushes the skin under the proxy and
 * the tool back, equal and opposite (reaction_mn), within lamina_sim_set_haptic_limits. With
 * the paper's constants, stiffness times the penetration of the deepest skin node inside the
 * sphere, routed over its rings and the layers behind it. Call it every frame with the
 * instrument's pose; lamina_sim_clear_tool_tip lifts it off. */
lamina_status lamina_sim_set_tool_tip(lamina_sim* sim, const double center_mm[3], double radius_mm,
                                      double stiffness_n_per_m);
lamina_status lamina_sim_clear_tool_tip(lamina_sim* sim);
/* The haptic rendering's limits for the next lamina_sim_set_tool_tip calls on a physical tissue:
 * the force on the tool (reaction_mn) never exceeds max_force_n (default 3 N) and changes by at
 * most max_force_change_n (default 0.05 N) a step. Both must be positive. */
lamina_status lamina_sim_set_haptic_limits(lamina_sim* sim, double max_force_n,
                                           double max_force_change_n);
/* A grasper (a second hand's forceps): the first call closes its jaws at `center_mm` on the skin
 * within `radius_mm` (every free skin node there is held where it is), later calls move them
 * there with what they hold (call it every frame with the instrument's pose), and
 * lamina_sim_release_grasper opens them. The tissue's pull on the held skin joins reaction_mn.
 * LAMINA_ERROR_INVALID_INPUT, nothing held, when no skin node is within radius_mm. */
lamina_status lamina_sim_set_grasper(lamina_sim* sim, const double center_mm[3], double radius_mm);
lamina_status lamina_sim_release_grasper(lamina_sim* sim);
/* Replaces every force held on skin nodes (count 0 releases them): forces_mn holds 3 * count
 * values, mN, each spread over the skin within 5 mm of its node on a physical tissue (the load
 * is the force), routed the paper's way from its node with the paper's constants. */
lamina_status lamina_sim_set_forces(lamina_sim* sim, const int32_t* skin_nodes,
                                    const double* forces_mn, int32_t count);

/* What the last step measured. */
typedef struct lamina_step_stats {
  double time_s;              /* simulated time after the step */
  int64_t steps;              /* steps since the start */
  double max_displacement_mm; /* largest node distance from rest */
  double volume_change_pct;   /* skin volume change, % */
  double reaction_mn[3];      /* the force on the tools, mN: minus their load on a physical
                                 tissue; the tissue's push back under the paper's routing */
  int32_t at_rest;            /* 1 when no node moves faster than the rest speed */
  int32_t tool_tip_touching;  /* 1 when the tool tip touches the skin */
  int64_t recoveries;         /* steps redone after a non-finite state */
  int32_t grasped_nodes;      /* skin nodes the grasper holds (0: open) */
} lamina_step_stats;

/* Takes `steps` steps of the solver's dt on the calling thread; `stats` (may be NULL) gets the
 * last one's measurements. LAMINA_ERROR_UNSTABLE once the simulation has left physical bounds
 * (steps failing in a row, energy growing while no tool acts, a stalled solver): it takes no
 * more steps, and its reaction is zero, until lamina_sim_reset. */
lamina_status lamina_sim_step(lamina_sim* sim, int32_t steps, lamina_step_stats* stats);
/* Puts every node back at rest (time 0); tool tip and forces are kept, the grasper opened. */
lamina_status lamina_sim_reset(lamina_sim* sim);

/* What a cut did. */
typedef struct lamina_cut_report {
  int64_t cut_tets;        /* tetrahedra divided (each is now two copies, one per side) */
  int32_t new_nodes;       /* nodes added: lamina_sim_node_count grows by this much */
  int32_t pieces;          /* connected pieces of the organ after it */
  double largest_piece_ml; /* the largest piece's volume, mL */
  int32_t structures_cut;  /* embedded structures (vessels, tumours) the blade cut across */
} lamina_cut_report;

/* Cuts the organ at once with a scalpel drawn on its current shape: the blade's upper end
 * along the `points` points of `path_xyz` (mm, interleaved, >= 2), reaching depth_mm along
 * `direction` (into the tissue). The tetrahedra it divides become two copies each (the virtual
 * node algorithm): the model (lamina_sim_model: the same handle, now the cut model), the node
 * count and every node index change (take positions and skin nodes again); forces, the tool tip
 * and the grasper carry over. `report` (may be NULL) says what it divided.
 * LAMINA_ERROR_INVALID_INPUT, nothing changed, for a bad path, depth or direction or a model
 * without tetrahedra. */
lamina_status lamina_sim_cut(lamina_sim* sim, const double* path_xyz, int32_t points,
                             const double direction[3], double depth_mm, lamina_cut_report* report);

int32_t lamina_sim_node_count(const lamina_sim* sim);
/* The simulation's model (owned by the simulation: do not free). */
const lamina_model* lamina_sim_model(const lamina_sim* sim);
/* Copies the current positions, mm, interleaved, into `xyz` (capacity >= 3 * node_count). */
lamina_status lamina_sim_positions(const lamina_sim* sim, double* xyz, int64_t capacity);
/* Writes embedded surface k's deformed positions (W x of the current positions), mm,
 * interleaved, into `xyz` (capacity >= 3 * vertex_count): a vertex buffer to upload each frame.
 * Allocates only on the first call for a surface. */
lamina_status lamina_sim_embedded_positions(lamina_sim* sim, int32_t k, double* xyz,
                                            int64_t capacity);

/* ---- worlds: several organs in contact and attached (docs/world.md) ----------------------- */

/* A world scene (a scene .json with "bodies"): every body's model made and prepared, placed
 * where the CT has it, the attachments tied, as `lamina run` sets it up; the scene's graspers
 * and dissections play on the world's clock as it steps. Bodies are named by their index,
 * 0..lamina_world_body_count-1, in the scene's order. LAMINA_ERROR_INVALID_INPUT for a scene
 * that is not a world scene (lamina_sim_create_from_scene takes those) or cannot be made. */
lamina_status lamina_world_create_from_scene(const char* scene, lamina_world** out);
void lamina_world_free(lamina_world* world);
int32_t lamina_world_body_count(const lamina_world* world);
/* Body `body`'s name (valid while the world lives), or NULL for an index out of range. */
const char* lamina_world_body_name(const lamina_world* world, int32_t body);
/* Body `body`'s model (owned by the world: do not free), or NULL for an index out of range. */
const lamina_model* lamina_world_body_model(const lamina_world* world, int32_t body);
/* Copies body `body`'s current positions, mm, interleaved (capacity >= 3 * its node count). */
lamina_status lamina_world_body_positions(const lamina_world* world, int32_t body, double* xyz,
                                          int64_t capacity);
/* Replaces the forces held on body `body`'s skin nodes (count 0 releases them), as
 * lamina_sim_set_forces does for one organ; the other bodies' forces are kept. */
lamina_status lamina_world_set_forces(lamina_world* world, int32_t body, const int32_t* skin_nodes,
                                      const double* forces_mn, int32_t count);
/* Sweeps a blade through the world at once (a dissection): its upper end along the `points`
 * points of `path_xyz` (mm, interleaved, >= 2), reaching depth_mm along `direction`; every tie
 * of the attachments within reach_mm of it is divided. `divided` (may be NULL) gets how many. */
lamina_status lamina_world_dissect(lamina_world* world, const double* path_xyz, int32_t points,
                                   const double direction[3], double depth_mm, double reach_mm,
                                   int32_t* divided);

/* Cuts at once every body the blade passes through (a scalpel, as `lamina view`'s K): its upper
 * end along the `points` points of `path_xyz` (mm, interleaved, >= 2), reaching depth_mm along
 * `direction`, drawn on the bodies as they are now; the ties it passes are divided too. A body
 * cut is renumbered: lamina_world_body_model's handle describes the cut model from now on (read
 * its counts again), lamina_world_body_topology moves on, and its forces go on, carried to their
 * nodes' first copies (set them again on its new nodes to change them). `tets_divided` (may be
 * NULL) gets how many tetrahedra were divided: 0 when the blade met no tissue. */
lamina_status lamina_world_cut(lamina_world* world, const double* path_xyz, int32_t points,
                               const double direction[3], double depth_mm, int64_t* tets_divided);
/* Takes the last lamina_world_cut back: every body it divided as it was just before it
 * (renumbered again: read its model's counts again; its forces carried back to the nodes their
 * copies came from), the ties it divided in
 * place again, the clock running on. The last 8 cuts can be undone, one call each;
 * LAMINA_ERROR_INVALID_INPUT when there is none. */
lamina_status lamina_world_undo_cut(lamina_world* world);
/* Body `body`'s topology generation: it moves on each time a cut (or an undo, or a reset putting
 * a cut body back) renumbers its nodes. 0 for an index out of range. */
uint32_t lamina_world_body_topology(const lamina_world* world, int32_t body);

/* What the last world step measured. */
typedef struct lamina_world_stats {
  double time_s;              /* simulated time after the step */
  int64_t steps;              /* steps since the start */
  double max_displacement_mm; /* largest node distance from rest, any body */
  double max_penetration_mm;  /* deepest skin node inside another skin (or its own), any body */
  int64_t ties;               /* the attachments' ties... */
  int64_t ties_divided;       /* ...divided by a blade... */
  int64_t ties_torn;          /* ...and torn past their strength */
  int32_t at_rest;            /* 1 when every body is at rest and no tie tore */
  double contact_us;          /* the last step's contact and ties stage, us */
  double step_us;             /* the last step, us */
} lamina_world_stats;

/* Takes `steps` steps of the world (every body at the scene's dt) on the calling thread;
 * `stats` (may be NULL) gets the last one's measurements. LAMINA_ERROR_UNSTABLE, naming the
 * body, once one has left physical bounds: no more steps until lamina_world_reset. */
lamina_status lamina_world_step(lamina_world* world, int32_t steps, lamina_world_stats* stats);
/* Every body back at rest, every tie in place, time 0 (the scene's tools and blades play
 * again); a body cut since is put back uncut (renumbered again: its forces released); the other
 * bodies' forces are kept. */
lamina_status lamina_world_reset(lamina_world* world);

/* ---- serving: 3D Slicer over OpenIGTLink, a browser or headset over the web ---------------- */

/* What lamina_serve listens on and streams: `lamina serve`'s main options (docs/openigtlink.md,
 * docs/web.md). lamina_serve_options_default fills in the command's defaults. */
typedef struct lamina_serve_options {
  const char* host;      /* OpenIGTLink's address; NULL = 127.0.0.1 (0.0.0.0: every interface) */
  int32_t port;          /* OpenIGTLink's; 18944 (3D Slicer's); 0 = any free one (logged) */
  int32_t web;           /* 1: the web page too (a world scene is served to it only) */
  const char* web_host;  /* the web server's address; NULL = 127.0.0.1 */
  int32_t web_port;      /* 8765; 0 = any free one (logged with the page's address) */
  const char* web_token; /* needed in the page's address; NULL = a random one (logged) */
  int32_t self_signed;   /* 1: TLS with a certificate made for the session (a headset's) */
  double rate_hz;        /* simulation steps per wall second (each 1 / rate of time); 1000 */
  double send_hz;        /* the skin's POLYDATA messages per second; 30 */
  double max_force_n;    /* the most the reaction sent back may be, N; 3 */
  double duration_s;     /* > 0: stop after this many wall seconds; 0 = until *stop */
} lamina_serve_options;

void lamina_serve_options_default(lamina_serve_options* options);

/* Serves what `lamina serve` takes (a scene .json, a model .vtu, a segmentation, "phantom"; a
 * world scene with web = 1) in real time on the calling thread until options->duration_s has
 * passed or *stop (may be NULL) becomes non-zero: set it from another thread or a signal
 * handler; it is read about every 0.1 s. The servers listen before the model is built (a port in
 * use fails at once). LAMINA_ERROR_INVALID_INPUT for bad options or input, nothing served;
 * LAMINA_ERROR_UNSTABLE when the simulation blew up during the serve (each blow-up is logged and
 * the organ reset; a world's ends the serve). */
lamina_status lamina_serve(const char* what, const lamina_serve_options* options,
                           const volatile int32_t* stop);

#ifdef __cplusplus
}
#endif

#endif /* LAMINA_C_API_H */
