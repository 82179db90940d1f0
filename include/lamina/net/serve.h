#pragma once
// The network edge (docs/openigtlink.md, docs/web.md): a simulation stepping in real time on its
// own thread, served to 3D Slicer over OpenIGTLink (tool poses in; the deformed surfaces and the
// tissue's reaction out) and, with `web`, to a browser or a headset over HTTP(S) and a WebSocket.
// A world of several organs is served the same way, each body's skin its own POLYDATA and the
// hands acting on any body. `lamina serve`, the Python module
// (lamina.serve) and the C API (lamina_sim_serve, lamina_world_serve) all serve through it.
//
// Usage:
//   net::ServeOptions o;  o.web = true;  o.duration_s = 60;
//   net::check_options(o);
//   net::Listening listening(o, /*igtl=*/true);  // before the model is built: a port in use fails
//   net::serve_organ(listening, std::move(sim), model, routing, o, "my organ", [] { return true;
//   });
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "lamina/world/dissection.h"
#include "lamina/world/organ_loop.h"
#include "lamina/world/world.h"

namespace lamina::net {

/// What a serve listens on, streams and takes. The fields are `lamina serve`'s options, and the
/// errors name them as it spells them (--send-hz for send_hz).
struct ServeOptions {
  std::string host = "127.0.0.1";  ///< OpenIGTLink's address (0.0.0.0: every interface)
  int port = 18944;                ///< OpenIGTLink's (and 3D Slicer's) default; 0 = any free one
  double send_hz = 30.0;           ///< POLYDATA messages per second; 0 = only on request
  /// POLYDATA messages per second of each embedded surface (display skin, structures: tens of
  /// thousands of triangles each); 0 = only on request.
  double embedded_hz = 10.0;
  /// Reaction-force messages per second, at most one per step (1000: every step of the 1 kHz
  /// loop, a haptic device's rate); 0 = one with each POLYDATA batch.
  double reaction_hz = 1000.0;
  bool all_layers = false;  ///< stream every layer, not only the skin
  double rate_hz = 1000.0;  ///< simulation steps per wall second, each 1 / rate of simulated time
  /// The rate follows the machine (interact/rate_choice.h) unless a client asks for one.
  bool auto_rate = false;
  double duration_s = 0.0;    ///< > 0: stop after this many wall seconds
  std::string frame = "ras";  ///< coordinates on the wire: ras (3D Slicer's) or lps (the model's)
  std::string tool_device;    ///< only poses with this device name move the tool; empty = any
  /// Poses with this device name move a grasper (its jaws close on the first, hold and follow);
  /// any message of this name + "Open" opens it.
  std::string grasper_device = "LaminaGrasper";
  double grasper_radius_mm = 4.0;  ///< skin within this distance of the jaws is grasped
  /// Poses with this device name are a scalpel's: a stroke's path cuts the organ when this
  /// name + "Up" comes, the poses pause or the client goes; + "Undo" takes the last cut back.
  /// Empty: no scalpel.
  std::string scalpel_device = "LaminaScalpel";
  double scalpel_depth_mm = 20.0;       ///< the blade's cutting length behind its tip, mm
  double scalpel_pause_s = 0.25;        ///< a stroke whose poses stop this long cuts
  double tip_radius_mm = 5.0;           ///< the tool tip's sphere (the viewer's default)
  double tip_stiffness_n_per_m = 20.0;  ///< its coupling (push per mm inside), N/m = mN/mm
  double max_force_n = 3.0;             ///< the most the reaction sent back may be, N
  double max_message_mb = 4.0;          ///< larger incoming messages drop their client
  double stall_timeout_s = 5.0;         ///< a client silent this long mid-message is dropped
  int max_clients = 16;
  int threads = 0;  ///< threads per step; 0 = OpenMP's default
  /// The web edge (docs/web.md): the page and its WebSocket stream, beside OpenIGTLink.
  bool web = false;
  std::string web_host = "127.0.0.1";  ///< the web server's address (--listen)
  int web_port = 8765;                 ///< 0 = any free one (logged)
  double web_hz = 60.0;                ///< frames per second to each page
  std::string web_token;               ///< empty: a random one (in the logged address)
  /// The page's files; empty: web/ beside the running program or the Lamina library (a build
  /// tree's), or the installed share/lamina/web.
  std::string web_root;
  bool self_signed = false;     ///< TLS with a certificate made for the session
  std::string cert, key;        ///< TLS with these PEM files
  double gain_n_per_mm = 0.01;  ///< a page's mouse drag: force per mm dragged
};

/// Throws lamina::Error (kInvalidInput) naming the first option that cannot be used.
void check_options(const ServeOptions& options);

/// The servers, listening. Open them before the model is built: a port in use fails at once,
/// and clients that connect meanwhile wait in the listen queue until the serve begins.
class Listening {
 public:
  /// Listens on OpenIGTLink's port (unless `igtl` is false: then the web page alone) and, with
  /// options.web, on the web server's (its TLS identity made or read).
  /// \note Throws lamina::Error (kInvalidInput) naming the option when an address cannot be
  ///   used, the page's files are missing or the certificate cannot be read.
  Listening(const ServeOptions& options, bool igtl);
  ~Listening();
  Listening(const Listening&) = delete;
  Listening& operator=(const Listening&) = delete;

  int igtl_port() const;        ///< the port OpenIGTLink listens on; 0 without it
  std::string web_url() const;  ///< the page's address with its token; "" without the web

  struct Servers;  ///< what serve_organ and serve_world take over (net's own)
  std::unique_ptr<Servers> servers;
};

/// Asked about every 0.1 s while serving; false ends the serve (Ctrl-C, a Python signal).
using KeepGoing = std::function<bool()>;

/// Serves one organ: `simulation` steps in real time (world::OrganLoop) at options.rate_hz
/// while this thread answers the clients, until `keep_going` says no or options.duration_s has
/// passed; a blow-up is said, counted and the organ reset. `source` names the organ in the log.
/// The servers are used up: a Listening serves once.
/// @return 0, or ErrorKind::kUnstable's code when the simulation became unstable at any time
int serve_organ(Listening& listening, sim::Simulation simulation,
                std::shared_ptr<const Model> model, const interact::RoutingOptions& routing,
                const ServeOptions& options, const std::string& source,
                const KeepGoing& keep_going);

/// Serves a world: it steps in real time (world::WorldLoop) with the scene's `dissections` on
/// its clock; over OpenIGTLink each body's skin goes out as a POLYDATA named after the body, a
/// tool's pose drives the world's tool tip, the grasper's device its grasper and the scalpel's
/// strokes cut every body they pass (docs/openigtlink.md, "A world"); the web page draws every
/// body. As serve_organ otherwise.
/// @return 0, or ErrorKind::kUnstable's code when a body became unstable (which ends the serve)
int serve_world(Listening& listening, world::World world,
                std::vector<world::Dissection> dissections, const ServeOptions& options,
                const std::string& source, const KeepGoing& keep_going);

}  // namespace lamina::net
