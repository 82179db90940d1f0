// web::Server (web_server.h) on Boost.Beast: asynchronous sessions driven by poll() from the
// serve loop's thread, so no handler ever runs beside another (no strands, no locks).
#include "web_server.h"

#include <fmt/format.h>

#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <type_traits>

#include "beast.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"

namespace lamina::net::web {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

std::string random_token() {
  std::random_device rd;
  std::string t;
  for (int k = 0; k < 4; ++k) t += fmt::format("{:08x}", rd());
  return t;
}

// Compares without an early exit, so that the time taken does not tell how much of a guess
// was right.
bool same(const std::string& a, const std::string& b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) diff |= static_cast<unsigned>(a[i] ^ b[i]);
  return diff == 0;
}

// The value of `key` in the target's query (?a=1&token=...), or empty.
std::string query_value(std::string_view target, std::string_view key) {
  const size_t q = target.find('?');
  if (q == std::string_view::npos) return {};
  std::string_view query = target.substr(q + 1);
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    const size_t eq = pair.find('=');
    if (eq != std::string_view::npos && pair.substr(0, eq) == key)
      return std::string(pair.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return {};
}

std::string_view path_of(std::string_view target) {
  return target.substr(0, target.find('?'));
}

const char* content_type(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".wasm") return "application/wasm";
  if (ext == ".png") return "image/png";
  return "application/octet-stream";
}

std::string peer_name(const tcp::socket& s) {
  beast::error_code ec;
  const tcp::endpoint e = s.remote_endpoint(ec);
  if (ec) return "?";
  return e.address().is_v6() ? fmt::format("[{}]:{}", e.address().to_string(), e.port())
                             : fmt::format("{}:{}", e.address().to_string(), e.port());
}

}  // namespace

struct Server::State : std::enable_shared_from_this<Server::State> {
  ServerOptions options;
  asio::io_context ioc;
  tcp::acceptor acceptor{ioc};
  ServerCounters counters;
  Opened opened;
  Handler handle;
  Closed closed;
  int next_id = 1;

  std::optional<asio::ssl::context> tls;  // with --self-signed or --cert: https and wss only

  // One WebSocket client: a read loop, and writes one at a time from its queue, then its frame.
  // The queue and the frame are the same over TCP and over TLS (ClientBase); the WebSocket is a
  // Client of one or the other.
  struct ClientBase {
    State& server;
    int id;
    std::string peer;
    struct Out {
      std::shared_ptr<const std::string> message;
      bool binary;
    };
    std::deque<Out> queue;  // setup, replies, events: all delivered, in order
    size_t queued_bytes = 0;
    std::shared_ptr<const std::string> frame;  // the newest frame not yet written
    bool writing = false;
    bool gone = false;

    ClientBase(State& s, int i, std::string p) : server(s), id(i), peer(std::move(p)) {}
    virtual ~ClientBase() = default;
    virtual void write_next() = 0;
    virtual void close() = 0;

    void enqueue(std::shared_ptr<const std::string> message, bool binary) {
      queued_bytes += message->size();
      queue.push_back({std::move(message), binary});
      if (queued_bytes > server.options.max_backlog_bytes)
        return server.drop(id, fmt::format("{} MB queued and not read", queued_bytes >> 20));
      write_next();
    }

    // The next message to write: the queue's first, else the newest frame.
    std::shared_ptr<const std::string> next(bool& binary, bool& is_frame) {
      if (!queue.empty()) {
        auto m = queue.front().message;
        binary = queue.front().binary;
        queued_bytes -= m->size();
        queue.pop_front();
        return m;
      }
      is_frame = true;
      return std::exchange(frame, nullptr);
    }
  };

  template <class Next>
  struct Client : ClientBase, std::enable_shared_from_this<Client<Next>> {
    websocket::stream<Next> ws;
    beast::flat_buffer in;

    Client(State& s, int i, std::string p, Next&& stream)
        : ClientBase(s, i, std::move(p)), ws(std::move(stream)) {}

    void read() {
      ws.async_read(in, [self = this->shared_from_this()](beast::error_code ec, size_t) {
        self->on_read(ec);
      });
    }

    void on_read(beast::error_code ec) {
      if (gone) return;
      if (ec == websocket::error::closed || ec == asio::error::eof ||
          ec == asio::error::connection_reset || ec == asio::error::not_connected ||
          ec == asio::error::broken_pipe || ec == asio::ssl::error::stream_truncated) {
        log::info("web client {} disconnected", peer);
        return server.remove(id);
      }
      if (ec == websocket::error::message_too_big)
        return server.drop(
            id, fmt::format("a message larger than {} bytes", server.options.max_message_bytes));
      if (ec == beast::error::timeout)
        return server.drop(id, "silent past the stall timeout (pings unanswered)");
      if (ec) return server.drop(id, "reading failed: " + ec.message());
      ++server.counters.messages_in;
      if (!ws.got_text()) return server.drop(id, "a binary message (the stream takes JSON text)");
      const std::string text = beast::buffers_to_string(in.data());
      in.consume(in.size());
      try {
        server.handle(id, peer, text);
      } catch (const Error& e) {
        return server.drop(id, e.what());
      }
      if (!gone) read();
    }

    void write_next() override {
      if (writing || gone) return;
      bool binary = true, is_frame = false;
      std::shared_ptr<const std::string> message = next(binary, is_frame);
      if (!message) return;
      writing = true;
      ws.binary(binary);
      ws.async_write(asio::buffer(*message), [self = this->shared_from_this(), message, is_frame](
                                                 beast::error_code ec, size_t bytes) {
        self->writing = false;
        if (self->gone) return;
        if (ec) return self->server.drop(self->id, "writing failed: " + ec.message());
        if (is_frame) {
          ++self->server.counters.frames_out;
          self->server.counters.bytes_out += static_cast<int64_t>(bytes);
        }
        self->write_next();
      });
    }

    void close() override {
      gone = true;
      beast::error_code ec;
      beast::get_lowest_layer(ws).socket().shutdown(tcp::socket::shutdown_both, ec);
      beast::get_lowest_layer(ws).close();
    }
  };

  std::map<int, std::shared_ptr<ClientBase>> clients;

  // An HTTP connection (over TCP, or TLS once its handshake is done) until it asks for the
  // WebSocket, or is answered and closed.
  template <class Stream>
  struct Request : std::enable_shared_from_this<Request<Stream>> {
    State& server;
    Stream stream;
    std::string peer;
    beast::flat_buffer buffer;
    std::optional<http::request_parser<http::string_body>> parser;

    template <class... Args>
    Request(State& s, tcp::socket&& socket, Args&... tls)
        : server(s),
          stream(std::move(socket), tls...),
          peer(peer_name(beast::get_lowest_layer(stream).socket())) {}

    auto& lowest() { return beast::get_lowest_layer(stream); }

    void expire() {
      lowest().expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(server.options.request_timeout_s)));
    }

    void start() {
      if constexpr (std::is_same_v<Stream, beast::tcp_stream>) {
        read();
      } else {
        expire();
        stream.async_handshake(asio::ssl::stream_base::server, [self = this->shared_from_this()](
                                                                   beast::error_code ec) {
          if (ec == beast::error::timeout) return self->quiet_close();  // a connection opened ahead
          if (ec) return self->refuse("the TLS handshake failed (" + ec.message() + ")");
          self->read();
        });
      }
    }

    void read() {
      parser.emplace();
      parser->header_limit(16 * 1024);
      parser->body_limit(16 * 1024);
      expire();
      http::async_read(
          stream, buffer, *parser,
          [self = this->shared_from_this()](beast::error_code ec, size_t) { self->on_read(ec); });
    }

    void quiet_close() {
      beast::error_code ignored;
      lowest().socket().shutdown(tcp::socket::shutdown_both, ignored);
      lowest().close();
    }

    void refuse(const std::string& problem) {
      log::warn("web client {}: {}; connection dropped", peer, problem);
      ++server.counters.dropped;
      quiet_close();
    }

    void answer(http::status status, std::string body, const char* type, bool keep_alive) {
      ++server.counters.requests;
      auto res = std::make_shared<http::response<http::string_body>>(status, 11);
      res->set(http::field::server, "lamina");
      res->set(http::field::content_type, type);
      res->set(http::field::cache_control, "no-store");
      res->keep_alive(keep_alive);
      res->body() = std::move(body);
      res->prepare_payload();
      http::async_write(stream, *res,
                        [self = this->shared_from_this(), res](beast::error_code ec, size_t) {
                          if (ec || !res->keep_alive()) return self->quiet_close();
                          self->read();
                        });
    }

    void on_read(beast::error_code ec) {
      if (ec == http::error::end_of_stream || ec == asio::error::eof ||
          ec == asio::error::connection_reset || ec == asio::ssl::error::stream_truncated)
        return quiet_close();  // the browser closed a kept-alive connection: nothing wrong
      if (ec == beast::error::timeout) {
        // A browser opens connections ahead of need and keeps answered ones open: one that has
        // sent nothing is closed quietly; half a request held open is a slowloris.
        if (!parser->got_some() && buffer.size() == 0) return quiet_close();
        return refuse(
            fmt::format("no whole request within {:g} s", server.options.request_timeout_s));
      }
      if (ec) return refuse("not an HTTP request (" + ec.message() + ")");
      const http::request<http::string_body>& req = parser->get();
      const std::string target(req.target());
      const std::string path(path_of(target));
      const bool token_ok = same(query_value(target, "token"), server.options.token);
      if (websocket::is_upgrade(req)) {
        if (path != "/stream") return refuse("a WebSocket for '" + path + "' (only /stream)");
        if (!token_ok) return refuse("a WebSocket without the session's token");
        if (static_cast<int>(server.clients.size()) >= server.options.max_clients)
          return refuse(
              fmt::format("refused, {} clients are connected already", server.clients.size()));
        return server.upgrade(std::move(stream), peer, parser->release());
      }
      if (req.method() != http::verb::get && req.method() != http::verb::head)
        return answer(http::status::method_not_allowed, "GET only\n", "text/plain", false);
      // The page needs the token; its scripts and styles do not (they are the same for anyone).
      std::string file = path == "/" ? "/index.html" : path;
      if (file == "/index.html" && !token_ok) {
        log::warn("web client {}: the page asked for without the session's token", peer);
        return answer(http::status::forbidden,
                      "This page needs the session's token: open the address lamina serve "
                      "printed (it ends in ?token=...).\n",
                      "text/plain; charset=utf-8", false);
      }
      if (file.find("..") != std::string::npos || file.find('\\') != std::string::npos)
        return answer(http::status::bad_request, "bad path\n", "text/plain", false);
      const std::string full = server.options.root + file;
      std::ifstream in(full, std::ios::binary);
      if (!in || std::filesystem::is_directory(full))
        return answer(http::status::not_found, "not found\n", "text/plain", req.keep_alive());
      std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      answer(http::status::ok, std::move(body), content_type(full), req.keep_alive());
    }
  };

  void accept() {
    acceptor.async_accept([self = shared_from_this()](beast::error_code ec, tcp::socket socket) {
      if (!self->acceptor.is_open()) return;
      if (!ec) {
        if (self->tls)
          std::make_shared<Request<beast::ssl_stream<beast::tcp_stream>>>(*self, std::move(socket),
                                                                          *self->tls)
              ->start();
        else
          std::make_shared<Request<beast::tcp_stream>>(*self, std::move(socket))->start();
      }
      self->accept();
    });
  }

  template <class Next>
  void upgrade(Next&& stream, const std::string& peer, http::request<http::string_body> req) {
    beast::get_lowest_layer(stream).expires_never();  // the WebSocket's own timeouts take over
    const int id = next_id++;
    auto client = std::make_shared<Client<Next>>(*this, id, peer, std::move(stream));
    websocket::stream_base::timeout t{};
    t.handshake_timeout = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(options.request_timeout_s));
    t.idle_timeout = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(options.stall_timeout_s));
    t.keep_alive_pings = true;
    client->ws.set_option(t);
    client->ws.read_message_max(options.max_message_bytes);
    client->ws.async_accept(req, [this, client](beast::error_code ec) {
      if (ec) {
        log::warn("web client {}: the WebSocket handshake failed ({}); connection dropped",
                  client->peer, ec.message());
        ++counters.dropped;
        return;
      }
      clients[client->id] = client;
      ++counters.clients;
      log::info("web client {} connected (client {})", client->peer, client->id);
      if (opened) opened(client->id, client->peer);
      client->read();
    });
  }

  void remove(int id) {
    const auto it = clients.find(id);
    if (it == clients.end()) return;
    const std::shared_ptr<ClientBase> c = it->second;
    clients.erase(it);
    c->close();
    if (closed) closed(id);
  }

  void drop(int id, const std::string& problem) {
    const auto it = clients.find(id);
    if (it == clients.end() || it->second->gone) return;
    log::warn("web client {}: {}; connection dropped", it->second->peer, problem);
    ++counters.dropped;
    remove(id);
  }
};

Server::Server(ServerOptions options) : state_(std::make_shared<State>()) {
  if (options.token.empty()) options.token = random_token();
  state_->options = std::move(options);
  const ServerOptions& o = state_->options;
  beast::error_code ec;
  const auto address = asio::ip::make_address(o.host, ec);
  if (ec) throw invalid_input("--listen", "'" + o.host + "' is not an IP address");
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(o.port));
  tcp::acceptor& a = state_->acceptor;
  a.open(endpoint.protocol(), ec);
  if (!ec) a.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) a.bind(endpoint, ec);
  if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
  if (ec)
    throw invalid_input("--web-port",
                        fmt::format("cannot listen on {}:{}: {}", o.host, o.port, ec.message()));
  if (o.tls) {
    // Modern TLS only (1.2 and 1.3): what headset browsers speak.
    asio::ssl::context& ctx = state_->tls.emplace(asio::ssl::context::tls_server);
    ctx.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                    asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                    asio::ssl::context::no_tlsv1_1);
    try {
      ctx.use_certificate_chain(asio::buffer(o.tls->certificate_pem));
      ctx.use_private_key(asio::buffer(o.tls->key_pem), asio::ssl::context::pem);
    } catch (const boost::system::system_error& e) {
      throw invalid_input(o.tls->source,
                          std::string("cannot use the certificate and key: ") + e.what());
    }
  }
  state_->accept();
}

Server::~Server() {
  beast::error_code ec;
  state_->acceptor.close(ec);
  for (auto& [id, c] : state_->clients) c->close();
  state_->clients.clear();
  state_->ioc.poll();  // let the handlers see the sockets closed
}

int Server::port() const {
  return state_->acceptor.local_endpoint().port();
}

const std::string& Server::token() const {
  return state_->options.token;
}

std::string Server::url() const {
  const std::string& h = state_->options.host;
  const std::string host = h == "0.0.0.0" ? "HOST" : h;
  return fmt::format("{}://{}:{}/?token={}", state_->tls ? "https" : "http", host, port(), token());
}

void Server::on(Opened opened, Handler handle, Closed closed) {
  state_->opened = std::move(opened);
  state_->handle = std::move(handle);
  state_->closed = std::move(closed);
}

void Server::poll() {
  state_->ioc.poll();
  if (state_->ioc.stopped()) state_->ioc.restart();
}

void Server::send(int client, std::shared_ptr<const std::string> message, bool binary) {
  const auto it = state_->clients.find(client);
  if (it != state_->clients.end()) it->second->enqueue(std::move(message), binary);
}

void Server::broadcast(std::shared_ptr<const std::string> message, bool binary) {
  for (const int id : client_ids()) send(id, message, binary);  // a send may drop a client
}

void Server::stream(std::shared_ptr<const std::string> frame) {
  for (auto& [id, c] : state_->clients) {
    if (c->frame) ++state_->counters.frames_skipped;
    c->frame = frame;
    c->write_next();
  }
}

int Server::client_count() const {
  return static_cast<int>(state_->clients.size());
}

std::vector<int> Server::client_ids() const {
  std::vector<int> ids;
  for (const auto& [id, c] : state_->clients) ids.push_back(id);
  return ids;
}

const ServerCounters& Server::counters() const {
  return state_->counters;
}

}  // namespace lamina::net::web
