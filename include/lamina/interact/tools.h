#pragma once
/// \file
/// Tools and the one pipeline from a tool to forces on nodes: *contact* finds where the tool
/// meets the skin and what load it puts there (contact.h: a force spread over the patch it
/// touches, a sphere's penalty), then *routing* either leaves that load as it is (Routing::kNone,
/// the physical tissue's: the tetrahedra carry it inward, and the tool feels exactly minus it) or
/// adds the reference paper's copies (Routing::kPaper: the force on the nearest skin node spread
/// over its BFS rings, and attenuated copies where the force line crosses the first P surfaces,
/// inner layers then the far side of the skin). Several tools at once, each with its own start
/// and end time.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "lamina/interact/grasp.h"
#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"

namespace lamina::interact {

/// What happens to a tool's load after contact.
enum class Routing {
  kPaper,  ///< the reference paper's: rings and attenuated copies along the force line
  kNone,   ///< the contact's load as it is: force conserved (the physical tissue's default)
};

/// Which surface a tool without routing touches (its contact and the patch its force spreads
/// over; the paper's routing always touches the skin's nodes).
enum class Touch {
  /// The model's display skin when it has one (the fine surface the viewer draws; its force
  /// reaches the nodes by the embedding's weights, W transposed), else the skin.
  kDisplaySkin,
  kSkin,  ///< the simulation's skin, layer 0
};

/// How a tool's force is distributed. Defaults reproduce the paper's figure 3 (N = 4, P = 4);
/// a physical scene sets `routing` to kNone (io::Scene's default).
struct RoutingOptions {
  Routing routing = Routing::kPaper;
  int32_t locality =
      4;  ///< N: rings 0..N-1 of each hit node receive force (<= model.rings.locality)
  int32_t penetration_depth =
      4;  ///< P: crossings of the force line that receive a copy, the contact included
  double ring_attenuation = 0.5;  ///< a node in ring r receives ring_attenuation^r of the copy
  double crossing_attenuation =
      0.95;  ///< crossing k (0 = the contact) receives crossing_attenuation^k of the force
  double contact_threshold_mm =
      10.0;  ///< a tool point farther than this from the skin touches nothing
  Touch touch = Touch::kDisplaySkin;  ///< the surface tools touch without routing
  /// 0: ring r is the nodes r mesh edges away (the paper's breadth-first rings), so a finer
  /// mesh spreads a tool's force over a smaller area. > 0: ring r is the layer's nodes whose
  /// distance at rest along the layer's edges rounds to r spacings (mm), the same area at every
  /// mesh size. kPaperRingSpacing: the spacing of the organ's paper-size skin
  /// (paper_ring_spacing_mm), the paper's reach at any resolution.
  double ring_spacing_mm = 0.0;
};

/// RoutingOptions::ring_spacing_mm's "the paper-size skin's edge", resolved per model.
inline constexpr double kPaperRingSpacing = -1.0;

/// The mean edge of a skin of 1,284 vertices (the paper's) with this model's skin area at rest,
/// mm: sqrt(4 A / (sqrt(3) (2 * 1284 - 4))) for a closed triangle mesh.
double paper_ring_spacing_mm(const Model& model);

/// `options` with kPaperRingSpacing replaced by the model's paper_ring_spacing_mm().
RoutingOptions resolve_ring_spacing(const RoutingOptions& options, const Model& model);

/// One node a copy of a routed force reaches and the ring it falls in.
struct RingMember {
  int32_t node = 0;
  int32_t ring = 0;
};

/// Node `v`'s rings 0..locality-1 by distance (`spacing_mm` > 0): the nodes of its layer whose
/// shortest path at rest along the layer's edges (ring 1 of each node in model.rings) rounds to
/// r spacings, ascending by node. With model.rings.locality < 2 (no edges kept) only v itself.
std::vector<RingMember> rings_by_distance(const Model& model, int32_t v, int32_t locality,
                                          double spacing_mm);

/// What is wrong with routing options for a model whose rings reach `rings_locality`: the key
/// (as in a scene's "solver" section) and the problem, or nothing. The one check of the options,
/// used by the scene reader, route_force(), the realtime loop and the Python binding.
struct RoutingProblem {
  std::string key;
  std::string problem;
};
std::optional<RoutingProblem> routing_problem(const RoutingOptions& options,
                                              int32_t rings_locality);
/// Throws lamina::Error (kInvalidInput) naming the key when routing_problem() finds one.
void check_routing(const RoutingOptions& options, int32_t rings_locality);

/// The radius of the patch a pushing tool's force is spread over without routing, mm: the
/// viewer's and the default tool tip's 5 mm.
inline constexpr double kDefaultPatchRadiusMm = 5.0;

/// A tool: where it touches (a point in mm, or a skin vertex), its force, and when it acts.
struct Tool {
  bool by_point = false;  ///< true: touch the skin nearest to point_mm
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  int32_t vertex = 0;                                  ///< used when !by_point: a skin node index
  Eigen::Vector3d force_mn = Eigen::Vector3d::Zero();  ///< mN (the scene file takes newtons)
  double start_s = 0.0;                                ///< acts from this time...
  double end_s = std::numeric_limits<double>::infinity();  ///< ...until this time, s
  /// Without routing: the force is spread over the skin within this distance of the contact
  /// point (contact.h, spread_on_patch). A grasper: the skin nodes within it are taken.
  double radius_mm = kDefaultPatchRadiusMm;
  /// A grasper instead of a push (grasp.h): at start_s its jaws close at the point (or the
  /// vertex), the skin under them follows the jaws as they move by pull_mm over pull_s
  /// (linearly, then held there), and at end_s they open. force_mn is not used.
  bool grasp = false;
  Eigen::Vector3d pull_mm = Eigen::Vector3d::Zero();
  double pull_s = 1.0;
};

/// A force held on a skin node (a mouse drag, a pinned drag), delivered like a Tool's.
struct LiveForce {
  int32_t node = -1;                                   ///< skin node the force is applied to
  Eigen::Vector3d force_mn = Eigen::Vector3d::Zero();  ///< mN
  double radius_mm = kDefaultPatchRadiusMm;            ///< the patch without routing
};

/// A spherical tool tip driven by a device's pose (`center_mm`). Without routing it is rendered
/// haptically (haptic_proxy.h): a proxy sphere follows the device but stays outside the skin
/// (god-object), and a virtual coupling spring of `stiffness_n_per_m` between them pushes the
/// tissue at the proxy's contact and the device back, equal and opposite, bounded by
/// `max_force_n` and changing by at most `max_force_change_n` a step. With the paper's routing:
/// stiffness times the penetration of the deepest skin node inside the sphere, routed.
struct ToolTip {
  bool active = false;
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 5.0;
  double stiffness_n_per_m = 20.0;   ///< coupling (penalty) stiffness: mN per mm
  double max_force_n = 3.0;          ///< the force sent back never exceeds this, N
  double max_force_change_n = 0.05;  ///< ... nor changes by more than this in one step, N
};

/// What is wrong with a tool tip (a key named as on `lamina serve`'s command line, and the
/// problem), or nothing: a radius or force limit that is not a positive number, a negative
/// stiffness, a centre that is not finite.
std::optional<RoutingProblem> tip_problem(const ToolTip& tip);

/// Where the force line crosses a layer.
struct Crossing {
  int32_t layer = 0;         ///< which surface
  int32_t node = 0;          ///< the crossed triangle's vertex nearest to the crossing point
  double distance_mm = 0.0;  ///< along the line from the contact node
};

/// A tool's load on the tissue, after contact and routing: the nodes that receive force and how
/// much. Without routing the forces sum to exactly minus the force on the tool.
struct ForceRoute {
  int32_t contact_node = -1;        ///< the skin node nearest to the contact (a marker, the rings)
  std::vector<Crossing> crossings;  ///< the paper's routing: the first P crossings, contact
                                    ///< first, in order along the line; empty without routing
  std::vector<int32_t> nodes;       ///< nodes receiving force, unique, ascending
  Eigen::MatrixX3d forces;          ///< #nodes by 3, mN, matching `nodes`
};

/// The crossings of the line from skin node `contact_node` in `direction` with every layer's
/// surface at positions x, ordered by distance; the contact itself comes first (distance 0).
std::vector<Crossing> force_line_crossings(const Model& model, const Eigen::MatrixX3d& x,
                                           int32_t contact_node, const Eigen::Vector3d& direction);

/// Distributes `force_mn` applied at skin node `contact_node` (positions x) the paper's way.
ForceRoute route_force(const Model& model, const Eigen::MatrixX3d& x, int32_t contact_node,
                       const Eigen::Vector3d& force_mn, const RoutingOptions& options = {});

/// The one pipeline from a pushing tool to forces on nodes (contact, then routing), used by the
/// tool driver, the realtime loop, the soak and validate alike.
/// A force on skin node `node`: spread over the patch of `radius_mm` around it (Routing::kNone),
/// or routed from that node the paper's way.
ForceRoute load_at_node(const Model& model, const Eigen::MatrixX3d& x, int32_t node,
                        const Eigen::Vector3d& force_mn, double radius_mm,
                        const RoutingOptions& options);
/// A force at `point_mm`: on the nearest skin point, spread over the patch (kNone), or routed
/// from the nearest skin node; an empty route (contact_node -1) when the skin is farther than
/// options.contact_threshold_mm.
ForceRoute load_at_point(const Model& model, const Eigen::MatrixX3d& x,
                         const Eigen::Vector3d& point_mm, const Eigen::Vector3d& force_mn,
                         double radius_mm, const RoutingOptions& options);
struct HapticProxy;
/// A tool tip's load at positions x, one step: the haptic proxy and its coupling (kNone,
/// haptic_proxy.h; `proxy` carries it between steps and holds the force on the device), or the
/// paper's: stiffness x the penetration of the deepest skin node inside the sphere, on that
/// node, routed (proxy.device_force_mn is minus that push). Empty when it touches nothing.
ForceRoute load_of_tip(const Model& model, const Eigen::MatrixX3d& x, const ToolTip& tip,
                       const RoutingOptions& options, HapticProxy& proxy);
/// The sum of a route's forces, mN: the load on the tissue (without routing, minus the force on
/// the tool).
Eigen::Vector3d total_force(const ForceRoute& route);

/// The skin node nearest to `point_mm` at positions x, or -1 if none is within threshold_mm.
/// Uses a k-d tree over the current skin positions (nanoflann).
int32_t nearest_skin_node(const Model& model, const Eigen::MatrixX3d& x,
                          const Eigen::Vector3d& point_mm, double threshold_mm);

/// The most anterior skin node at rest (smallest y in LPS; the first of equals): where the
/// reference paper's poke, the default scene's tool and `lamina validate`'s indenter touch.
int32_t most_anterior_skin_node(const Model& model);

/// External forces written sparsely: the nodes that were given force, so that clearing them
/// costs in proportion to them and not to the model (a 1 kHz loop on a 100k-node model).
struct Loads {
  std::vector<int32_t> nodes;  ///< every node written since the last clear (may repeat)
  bool cleared = false;        ///< the whole f_ext was zeroed once
};

/// Zeroes f_ext at the loaded nodes (the whole of f_ext on the first call) and forgets them.
void clear_loads(sim::Simulation& sim, Loads& loads);

/// Adds a route's forces to f_ext and records its nodes.
void add_load(sim::Simulation& sim, const ForceRoute& route, Loads& loads);

/// The paper's local mode moves only the nodes made movable; every node a force has loaded
/// (`touched`) stays movable, so that a released region can return to rest. Sorts `touched` and
/// drops repeats; in local mode, makes exactly those nodes movable (nothing more in global mode,
/// where every free node moves). Shared by the tool driver, the realtime loop and the soak.
void keep_touched_movable(sim::Simulation& sim, std::vector<int32_t>& touched);

/// Drives a simulation with tools: activates and releases them by time, routes their forces into
/// sim.f_ext, and in local mode makes exactly the ring nodes movable.
// (Every member has an initialiser, so that `{.tools = t, .routing = r}` names only what it sets.)
struct ToolDriver {
  std::vector<Tool> tools{};
  RoutingOptions routing{};
  std::vector<ForceRoute> routes{};  ///< per tool; computed when the tool starts
  std::vector<uint8_t> active{};     ///< per tool
  /// Local mode: every node that has received force since the start stays movable, so that a
  /// released region can return to rest.
  std::vector<int32_t> touched{};
  Loads loads{};                ///< the nodes apply_tools() gave force
  std::vector<Grasp> grasps{};  ///< per tool; what a grasper holds while it acts
  /// Forces held on nodes besides the tools', mN: #nodes by 3, or empty. When given,
  /// apply_tools() starts f_ext from them each step instead of from zero (the Python module's
  /// raw forces, which the tools add to).
  Eigen::MatrixX3d held_forces{};
  /// A loop's live hands, besides the scripted tools, so that one driver holds everything that
  /// names the body's nodes (a cut carries all of it: carry_tools()). `live_routes`: the users'
  /// live forces, routed on the shape of the moment they were set and added every step; `tip`:
  /// the tool tip's load this step (its haptic proxy's); `hand`: what a live grasper holds (the
  /// loop moves its jaws; apply_tools() leaves it alone).
  std::vector<ForceRoute> live_routes{};
  ForceRoute tip{};
  Grasp hand{};
};

/// Updates sim.f_ext (and, in local mode, the movable nodes) for time sim.time_s.
/// \note Throws lamina::Error (kInvalidInput) for a tool vertex outside the skin or a tool
///   point that touches no skin node.
/// @return true if any tool is active
bool apply_tools(sim::Simulation& sim, ToolDriver& driver);

/// The tissue's push back on the tools, mN: the spring and anchor forces on every free node of
/// `loads` that receives external force (a held node's share goes into its support). At rest
/// under a held load it balances the load; a haptic device renders it. Costs a pass over the
/// loaded nodes' springs only.
Eigen::Vector3d reaction_force(const sim::Simulation& sim, const Loads& loads);

/// The force on every tool at once, mN: the tissue's push back on the pushing tools
/// (reaction_force() of driver.loads) plus each grasper's pull (grasp_reaction()).
Eigen::Vector3d tools_reaction(const sim::Simulation& sim, const ToolDriver& driver);

/// The tissue's push back on a real-time loop's live hands on a body, mN, after a step: without
/// routing exactly minus the live forces' loads (Newton's third law) plus the tool tip's device
/// force (its coupling's: bounded, continuous); with the paper's routing, whose copies are not
/// a tool's load, the tissue's push on the loaded nodes (reaction_force()); in either, the live
/// grasper's pull on what it holds.
Eigen::Vector3d live_reaction(const sim::Simulation& sim, const ToolDriver& driver,
                              const Eigen::Vector3d& device_force_mn);

/// The time after which no tool acts any more (0 with no tools; infinity if one never ends).
double last_tool_end(const ToolDriver& driver);

}  // namespace lamina::interact
