// ThreadSanitizer run over `lamina serve --web`'s edge (scripts/tsan.sh, docs/web.md): the
// realtime loop steps on its thread while this thread runs the web session as the serve loop
// does (web::Session::poll: the network, the pages' messages onto the loop, frames out), and two
// page threads, each a WebSocket client, push and grasp with their hands and read frames as fast
// as they come. Any data race is a TSan report and a non-zero exit; the program also checks that
// both pages were streamed, that frames said a page's hand held a tool, and that the skin moved.
//   tsan_web_session MODEL.vtu [SECONDS]
#include "web_session.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "beast.h"
#include "handoff_setup.h"
#include "lamina/core/error.h"
#include "lamina/world/organ_loop.h"

using namespace lamina;
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using json = nlohmann::json;

namespace {

// A page: reads the setup, then sends a hand each frame it reads (the trigger held at `tip` for
// the first half, the grip for the second) until `stop`.
void page(int port, const std::string& token, int hand, Eigen::Vector3d tip,
          const std::atomic<bool>& stop, std::atomic<int>& frames, std::atomic<double>& moved,
          std::atomic<int>& held, std::atomic<bool>& finished) {
  try {
    asio::io_context ioc;
    websocket::stream<beast::tcp_stream> ws(ioc);
    beast::get_lowest_layer(ws).connect(
        {asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)});
    ws.handshake("127.0.0.1", "/stream?token=" + token);
    beast::flat_buffer b;
    ws.read(b);
    const json hello = json::parse(beast::buffers_to_string(b.data()));
    std::vector<uint16_t> rest;
    for (size_t k = 0; k <= hello["surfaces"].size(); ++k) {
      b.clear();
      ws.read(b);
      if (k == hello["surfaces"].size())
        rest = net::web::decode_rest(beast::buffers_to_string(b.data()));
    }
    uint32_t pose = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (!stop) {
      b.clear();
      ws.read(b);
      if (ws.got_text()) continue;
      net::web::FrameInfo info;
      const std::vector<uint16_t> q =
          net::web::decode_frame(beast::buffers_to_string(b.data()), rest, &info);
      if (info.tools[0].client >= 0 || info.tools[1].client >= 0) ++held;
      double most = 0.0;
      for (size_t k = 0; k < q.size(); ++k)
        most = std::max(most, std::abs(double(q[k]) - double(rest[k])));
      moved = std::max(moved.load(), most * hello["step_mm"].get<double>());
      ++frames;
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const bool push = static_cast<int>(t) % 2 == 0;
      ws.text(true);
      ws.write(asio::buffer(json{
          {"type", "hand"},
          {"hand", hand},
          {"pose", ++pose},
          {"position", {tip.x(), tip.y(), tip.z()}},
          {"trigger", push ? 1.0 : 0.0},
          {"grip",
           push ? 0.0 : 1.0}}.dump()));
    }
    ws.close(websocket::close_code::normal);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "page %d: %s\n", hand, e.what());
  }
  finished = true;
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<tsan::HandoffSetup> setup = tsan::handoff_setup(argc, argv);
  if (!setup) return 2;
  const std::shared_ptr<Model> model = setup->model;
  const double seconds = setup->seconds;
  const sim::Material& material = setup->material;
  world::LoopOptions options;
  options.rate_hz = 1000.0;
  world::OrganLoop loop(sim::make_simulation(*model, material), {}, options);
  interact::ToolTip tip;
  int tip_client = -1, grasper_client = -1;
  net::web::ServerOptions so;
  so.port = 0;
  so.root = ".";
  auto server = std::make_unique<net::web::Server>(so);
  const int port = server->port();
  const std::string token = server->token();
  net::web::Session session(std::move(server), {.frame_hz = 120.0}, loop,
                            {tip, tip_client, grasper_client}, model);
  loop.start();
  // Each page's hand at the skin's farthest point along +x or -x, 3 mm inside.
  Eigen::Index right = 0, left = 0;
  model->X.col(0).maxCoeff(&right);
  model->X.col(0).minCoeff(&left);
  const Eigen::Vector3d at_right = model->X.row(right).transpose() - Eigen::Vector3d(3, 0, 0);
  const Eigen::Vector3d at_left = model->X.row(left).transpose() + Eigen::Vector3d(3, 0, 0);
  std::atomic<bool> stop{false}, finished0{false}, finished1{false};
  std::atomic<int> frames0{0}, frames1{0}, held{0};
  std::atomic<double> moved0{0.0}, moved1{0.0};
  std::thread p0(page, port, token, 0, at_right, std::cref(stop), std::ref(frames0),
                 std::ref(moved0), std::ref(held), std::ref(finished0));
  std::thread p1(page, port, token, 1, at_left, std::cref(stop), std::ref(frames1),
                 std::ref(moved1), std::ref(held), std::ref(finished1));
  // This thread is the serve loop's network thread: it polls the session, as run_serve does.
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  while (elapsed() < seconds) {
    const double wait = session.poll();
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait, 0.001)));
  }
  stop = true;  // each page leaves after its next frame: keep streaming until both have
  while ((!finished0 || !finished1) && elapsed() < seconds + 10.0) {
    session.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  p0.join();
  p1.join();
  loop.stop();
  session.log_summary();
  const double moved = std::max(moved0.load(), moved1.load());
  std::printf(
      "tsan_web_session: %d and %d frames to the two pages, %d of them with a tool held, the "
      "skin moved %.2f mm\n",
      frames0.load(), frames1.load(), held.load(), moved);
  return frames0 > 20 && frames1 > 20 && held > 10 && moved > 0.0 ? 0 : 1;
}
