// web::Session (web_session.h): a browser's messages (docs/web.md "Messages from the page") onto
// the serve loop's simulation, and the frames back.
#include "web_session.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/pick.h"
#include "scalpel_stroke.h"
#include "serve_clock.h"
#include "web_message.h"

namespace lamina::net::web {
namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

}  // namespace

Session::Session(std::unique_ptr<Server> server, SessionOptions options, world::OrganLoop& loop,
                 SharedTools tools, std::shared_ptr<const Model> model)
    : server_(std::move(server)), options_(std::move(options)), loop_(loop), tools_(tools) {
  stream_ = std::make_unique<WebStream>(std::move(model), options_.hello_fields);
  server_->on([this](int client, const std::string&) { opened(client); },
              [this](int client, const std::string& peer, const std::string& text) {
                handle(client, peer, text);
              },
              [this](int client) { closed(client); });
  next_frame_ = Clock::now();
  log::info("web: {} surfaces, {} triangles, carried by {} {}", stream_->setup().size() - 1,
            stream_->drawn_triangles(), stream_->streamed_points(),
            stream_->by_nodes() ? "nodes" : "vertices");
}

void Session::opened(int client) {
  server_->send(
      client, std::make_shared<const std::string>(stream_->hello(client + kWebClientBase)), false);
  for (const std::string& m : stream_->setup())
    server_->send(client, std::make_shared<const std::string>(m), true);
}

void Session::event(int client, const std::string& text, bool bad) {
  server_->send(client,
                std::make_shared<const std::string>(
                    json{{"type", "event"}, {"text", text}, {"bad", bad}}.dump()),
                false);
}

void Session::release_tip() {
  tip_hand_ = {};
  tools_.tip_client = -1;
  tools_.tip.active = false;
  loop_.set_tool_tip(tools_.tip);
}

void Session::release_grasper() {
  grasp_hand_ = {};
  tools_.grasper_client = -1;
  loop_.set_grasper(std::nullopt);
}

void Session::tools_changed() {
  if (tools_.tip_client != tip_hand_.client) tip_hand_ = {};
  if (tools_.grasper_client != grasp_hand_.client) grasp_hand_ = {};
}

void Session::handle(int client, const std::string& peer, const std::string& text) {
  const json m = parse_message(text);
  const std::string type = m["type"].get<std::string>();
  const int id = client + kWebClientBase;
  tools_changed();
  if (type == "hand") {
    // A controller: its tip's position (mm, the model's frame), trigger and grip in [0, 1].
    const auto [hand, pose, p, trigger, grip] = read_hand(m);
    const bool holds_tip = tip_hand_.client == id && tip_hand_.hand == hand;
    if (trigger && (tools_.tip_client < 0 || holds_tip)) {
      if (!holds_tip) log::info("web client {}: hand {} drives the tool tip", peer, hand);
      tools_.tip_client = id;
      tools_.tip.center_mm = p;
      tools_.tip.active = true;
      loop_.set_tool_tip(tools_.tip);
      tip_hand_ = {id,          hand, pose, loop_.latest_reaction().steps, tip_hand_.reflected,
                   Clock::now()};
    } else if (!trigger && holds_tip) {
      release_tip();
    }
    const bool holds_grasper = grasp_hand_.client == id && grasp_hand_.hand == hand;
    if (grip && (tools_.grasper_client < 0 || holds_grasper)) {
      try {
        loop_.set_grasper(interact::Jaws{.center_mm = p, .radius_mm = options_.grasp_radius_mm});
      } catch (const Error& e) {  // nothing under the jaws: said to that page, nothing held
        if (!holds_grasper && !grasp_missed_) {
          log::info("web client {}: hand {}'s grasp: {}", peer, hand, e.what());
          event(client, e.what(), false);
        }
        grasp_missed_ = true;
        return;
      }
      grasp_missed_ = false;
      if (!holds_grasper) log::info("web client {}: hand {} closes the grasper", peer, hand);
      tools_.grasper_client = id;
      grasp_hand_ = {id,          hand, pose, loop_.latest_reaction().steps, grasp_hand_.reflected,
                     Clock::now()};
    } else if (!grip && holds_grasper) {
      release_grasper();
    } else if (!grip) {
      grasp_missed_ = false;
    }
  } else if (type == "press") {
    // The desktop's mouse: a ray (model frame) picks the skin node to push or pull.
    const Eigen::Vector3d origin = vector3(m, "origin", 1e6);
    const Eigen::Vector3d direction = vector3(m, "direction", 1e6);
    if (!(direction.norm() > 0.0)) throw invalid_input("message", "'direction' has zero length");
    loop_.latest(snap_);
    const Model& model = snap_.model ? *snap_.model : stream_->model();
    const interact::SkinHit hit =
        interact::pick_skin(model, snap_.x, origin, direction.normalized());
    drag_node_ = hit.node;
    drag_version_ = snap_.model_version;
    drag_client_ = hit.node >= 0 ? client : -1;
    if (hit.node >= 0) log::info("web client {}: drags node {}", peer, hit.node);
  } else if (type == "drag") {
    const Eigen::Vector3d drag = vector3(m, "drag_mm", 1e4);
    if (drag_client_ != client) return;
    loop_.latest(snap_);
    follow_drag();
    if (drag_node_ < 0) return;
    try {
      loop_.set_forces({interact::LiveForce{.node = drag_node_,
                                            .force_mn = 1000.0 * options_.gain_n_per_mm * drag}},
                       drag_version_);
    } catch (const Error&) {  // a cut or an undo came in meanwhile: the next message follows it
    }
  } else if (type == "release") {
    if (drag_client_ == client) {
      loop_.set_forces({});
      drag_client_ = -1;
      drag_node_ = -1;
    }
  } else if (type == "plan") {
    // The resection plane (model frame): the plan on the organ's current shape, to this page.
    const Eigen::Vector3d point = vector3(m, "point", 1e6), normal = vector3(m, "normal", 1e6);
    if (!(normal.norm() > 0.0)) throw invalid_input("message", "'normal' has zero length");
    loop_.latest(snap_);
    const Model& model = snap_.model ? *snap_.model : stream_->model();
    const Eigen::MatrixX3d& x = snap_.x.rows() == model.node_count() ? snap_.x : model.X;
    const std::string reply =
        options_.plan
            ? options_.plan(model, snap_.model_version, x, point, normal.normalized())
            : json{{"type", "plan"}, {"error", "this server does not plan resections"}}.dump();
    server_->send(client, std::make_shared<const std::string>(reply), false);
  } else {
    throw invalid_input("message", "unknown type '" + type + "'");
  }
}

// A cut or an undo renumbers the nodes; the loop carried the drag's force to its node's first
// copy (or back), so the drag goes on there. A drag whose force was not carried (pressed, not yet
// pulled; or let go by a reset) ends quietly: the page's next drag is ignored until it presses
// again.
void Session::follow_drag() {
  if (snap_.model_version == drag_version_ || drag_node_ < 0) return;
  drag_version_ = snap_.model_version;
  drag_node_ = snap_.force_nodes.size() == 1 ? snap_.force_nodes[0] : -1;
  if (drag_node_ < 0) drag_client_ = -1;
}

void Session::closed(int client) {
  const int id = client + kWebClientBase;
  tools_changed();
  if (tip_hand_.client == id) {
    release_tip();
    log::info("the tool tip is released: its web client has gone");
  }
  if (grasp_hand_.client == id) {
    release_grasper();
    log::info("the grasper opens: its web client has gone");
  }
  if (drag_client_ == client) {
    loop_.set_forces({});
    drag_client_ = -1;
  }
}

void Session::send_frame() {
  loop_.latest(snap_);
  // A cut makes another model: every page hears what it divided (the vessels crossed, in the
  // model's frame) and is sent the new model.
  if (snap_.model && snap_.model_version != stream_version_) {
    if (snap_.cuts > cuts_seen_) {
      json cut = json::parse(cut_event_text(snap_, igtlink::Frame::kLps));
      cut["type"] = "cut";
      server_->broadcast(std::make_shared<const std::string>(cut.dump()), false);
    }
    cuts_seen_ = snap_.cuts;
    stream_ = std::make_unique<WebStream>(snap_.model, options_.hello_fields);
    stream_version_ = snap_.model_version;
    for (int c : server_->client_ids()) opened(c);
  }
  FrameInfo info;
  info.frame = ++frames_;
  info.model_version = static_cast<uint32_t>(stream_version_);
  info.time_s = snap_.time_s;
  info.steps = snap_.steps;
  info.sent_at_us = static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
          .count());
  tools_changed();
  Hand* held[2] = {&tip_hand_, &grasp_hand_};
  for (int k = 0; k < 2; ++k) {
    Hand& h = *held[k];
    ToolInfo& t = info.tools[k];
    if (h.client < 0) continue;
    t.client = h.client;
    t.hand = h.hand;
    // The newest pose applied before the snapshot's step (a pose applied after it is not in it).
    if (snap_.steps > h.pose_step && h.reflected != h.pose) {
      h.reflected = h.pose;
      if (pose_to_frame_ms_.size() < 100000)
        pose_to_frame_ms_.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - h.pose_at).count());
    }
    t.pose = h.reflected;
    t.reaction_mn = snap_.reaction_mn;  // the tissue's push on the tools, together
    t.contact = k == 0 ? !snap_.contact_nodes.empty() : !snap_.grasped_nodes.empty();
  }
  info.volume_change_percent = snap_.stats.volume_change_pct;
  info.unstable = snap_.stats.unstable != sim::Instability::kNone;
  info.behind = !snap_.keeping_up;
  const auto t0 = Clock::now();
  auto frame = std::make_shared<const std::string>(stream_->frame(snap_.x, info));
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (encode_ms_.size() < 100000) {
    encode_ms_.push_back(ms);
    frame_kb_.push_back(static_cast<double>(frame->size()) / 1e3);
  }
  server_->stream(std::move(frame));
}

double Session::poll() {
  server_->poll();
  if (server_->client_count() == 0) return 0.01;  // accept within 10 ms
  if (frame_due(next_frame_, every(options_.frame_hz))) {
    send_frame();
    server_->poll();
  }
  // Messages from the pages wait at most a millisecond (a pose reaches the loop at once).
  return 0.001;
}

void Session::log_summary() const {
  const ServerCounters& c = server_->counters();
  log::info(
      "web: {} clients, {} messages in, {} frames out ({:.1f} MB, median {:.1f} kB a frame, "
      "encoded in {:.2f} ms median), {} frames skipped for busy clients, {} connections dropped; "
      "a pose to the first frame showing it: {:.1f} ms median ({} poses)",
      c.clients, c.messages_in, c.frames_out, static_cast<double>(c.bytes_out) / (1 << 20),
      median(frame_kb_), median(encode_ms_), c.frames_skipped, c.dropped, median(pose_to_frame_ms_),
      pose_to_frame_ms_.size());
}

}  // namespace lamina::net::web
