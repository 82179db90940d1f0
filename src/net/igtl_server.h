#pragma once
/// \file
/// The OpenIGTLink server under `lamina serve`: a listening TCP socket and its clients, read and
/// written without blocking from one thread, which is never the simulation's. A client that
/// sends something that is not OpenIGTLink, too large, corrupt (bad CRC), or that stops in the
/// middle of a message is dropped with one log line naming it and the problem; the others carry
/// on. Messages of a type the caller does not use are skipped, as the protocol says.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "igtl_wire.h"

namespace lamina::net::igtlink {

struct ServerOptions {
  std::string host = "127.0.0.1";      ///< the address to listen on (0.0.0.0: every interface)
  int port = 18944;                    ///< 3D Slicer's default; 0 = a free port (Server::port())
  uint64_t max_body_bytes = 4u << 20;  ///< a message declaring a larger body is refused
  /// A client silent for this long in the middle of a message is dropped, s. Between messages
  /// a client may stay silent for as long as it likes.
  double stall_timeout_s = 5.0;
  int max_clients = 16;  ///< connections beyond this are closed at once, with a log line
  /// Replies queued for a client that does not read them; beyond this it is dropped, bytes.
  size_t max_backlog_bytes = 64u << 20;
};

/// A complete message from a client whose body passed its CRC check.
struct Message {
  int client = 0;    ///< the client's id (stable while it is connected)
  std::string peer;  ///< "ADDRESS:PORT", for messages
  Header header;
  const uint8_t* content = nullptr;  ///< valid during the handler only
  size_t size = 0;
};

/// What the server did since it started.
struct ServerCounters {
  int64_t clients = 0;         ///< connections accepted
  int64_t messages_in = 0;     ///< complete, checked messages received
  int64_t messages_out = 0;    ///< messages written or queued
  int64_t bytes_out = 0;       ///< their bytes
  int64_t dropped = 0;         ///< connections closed by the server on a problem
  int64_t frames_skipped = 0;  ///< streamed batches not sent to a client still busy with one
};

/// What streamed messages belong to, each skipped for a busy client on its own.
enum class Stream : uint8_t {
  kSurfaces,  ///< the layers' POLYDATA and the reaction (--send-hz, --reaction-hz)
  kEmbedded,  ///< the embedded surfaces' POLYDATA (--embedded-hz)
};
inline constexpr size_t kStreams = 2;

class Server {
 public:
  /// Listens on options.host:options.port.
  /// \note Throws lamina::Error (kInvalidInput) naming --host or --port when the address cannot
  ///   be used (unknown host, port in use).
  explicit Server(const ServerOptions& options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  int port() const;  ///< the port listened on (the one the system chose for port 0)

  /// Called for each complete message; a lamina::Error it throws drops that client with a log
  /// line naming the problem.
  using Handler = std::function<void(const Message&)>;
  /// Called when a client has gone, for whatever reason.
  using Closed = std::function<void(int client)>;

  /// Waits at most `timeout_s` for the network, then accepts, reads, hands over complete
  /// messages and writes what the sockets take. Never blocks longer than `timeout_s`.
  void poll(double timeout_s, const Handler& handle, const Closed& closed);

  /// Queues a reply for one client.
  void send(int client, const Packed& message);
  /// Queues a message for every client, however busy (an event each must get, once).
  void broadcast(const Packed& message);
  /// Queues a batch of streamed messages for every client, except one that has not yet taken
  /// the previous batch of the same stream (a slow client gets fewer frames, never a growing
  /// queue; a large message of one stream does not make a client miss the other's).
  void stream(const std::vector<Packed>& batch, Stream stream);

  int client_count() const;
  const ServerCounters& counters() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace lamina::net::igtlink
