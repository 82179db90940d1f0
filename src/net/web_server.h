#pragma once
/// \file
/// The web edge of `lamina serve --web` (docs/web.md): an HTTP server for the page's files and a
/// WebSocket for the stream, on Boost.Beast, run from the serve loop's network thread (poll()),
/// never the simulation's. The page and the stream need the session's token in the URL. A client
/// that sends something malformed, oversized, not JSON, without the token, or that stalls in its
/// request is dropped with one log line naming it and the problem; the others carry on. Frames
/// are streamed newest-wins: a client still taking one frame gets the newest next, never a queue.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lamina::net::web {

/// A certificate and its private key, PEM, for https and wss (web_tls.h makes or reads them).
struct TlsIdentity {
  std::string certificate_pem, key_pem;
  std::string fingerprint_sha256;  ///< the certificate's, AA:BB:..., to check in a browser
  std::string source;              ///< the files they came from, or "--self-signed"
};

struct ServerOptions {
  std::string host = "127.0.0.1";  ///< the address to listen on (0.0.0.0: every interface)
  int port = 8443;                 ///< 0 = a free port (Server::port())
  std::string token;               ///< needed in the URL (?token=); empty: a random one is made
  std::string root;                ///< the page's files (index.html, its scripts)
  size_t max_message_bytes = 64u << 10;  ///< a larger WebSocket message drops its client
  double request_timeout_s = 5.0;  ///< a request (or WebSocket handshake) must be whole by then
  double stall_timeout_s = 10.0;   ///< a WebSocket silent this long (pings unanswered) is dropped
  int max_clients = 8;             ///< WebSocket clients beyond this are refused
  size_t max_backlog_bytes = 64u << 20;  ///< setup and events queued for a client not reading
  /// Given: https and wss only (a headset's browser grants WebXR only to a secure context, which
  /// plain http off localhost is not).
  std::optional<TlsIdentity> tls;
};

struct ServerCounters {
  int64_t requests = 0;        ///< HTTP requests answered (files and refusals)
  int64_t clients = 0;         ///< WebSocket clients accepted
  int64_t messages_in = 0;     ///< WebSocket messages received
  int64_t frames_out = 0;      ///< frames written
  int64_t bytes_out = 0;       ///< their bytes
  int64_t frames_skipped = 0;  ///< frames replaced by a newer one before a busy client took them
  int64_t dropped = 0;         ///< connections closed by the server on a problem
};

class Server {
 public:
  /// Listens on options.host:options.port.
  /// \note Throws lamina::Error (kInvalidInput) naming --listen or --web-port when the address
  ///   cannot be used.
  explicit Server(ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  int port() const;
  const std::string& token() const;
  /// The page's address, with the token.
  std::string url() const;

  /// A WebSocket client has connected (send it the setup now).
  using Opened = std::function<void(int client, const std::string& peer)>;
  /// A text message from a client; a lamina::Error it throws drops that client with a log line.
  using Handler = std::function<void(int client, const std::string& peer, const std::string& text)>;
  using Closed = std::function<void(int client)>;
  void on(Opened opened, Handler handle, Closed closed);

  /// Runs what the network has ready, without waiting.
  void poll();

  /// Queues a message for one client, text or binary (setup, replies: each delivered, in order).
  void send(int client, std::shared_ptr<const std::string> message, bool binary);
  /// Queues a message for every client (events).
  void broadcast(std::shared_ptr<const std::string> message, bool binary);
  /// Streams a frame to every client: written at once to an idle client; to a busy one, it
  /// replaces the frame still waiting (newest wins).
  void stream(std::shared_ptr<const std::string> frame);

  int client_count() const;
  std::vector<int> client_ids() const;
  const ServerCounters& counters() const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace lamina::net::web
