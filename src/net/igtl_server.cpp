#include "igtl_server.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>

#include "lamina/core/error.h"
#include "lamina/core/log.h"

namespace lamina::net::igtlink {
namespace {

using Clock = std::chrono::steady_clock;

std::string address_name(const sockaddr_storage& a) {
  char host[INET6_ADDRSTRLEN] = "?";
  if (a.ss_family == AF_INET) {
    const auto& in = reinterpret_cast<const sockaddr_in&>(a);
    inet_ntop(AF_INET, &in.sin_addr, host, sizeof(host));
    return fmt::format("{}:{}", host, ntohs(in.sin_port));
  }
  if (a.ss_family == AF_INET6) {
    const auto& in6 = reinterpret_cast<const sockaddr_in6&>(a);
    inet_ntop(AF_INET6, &in6.sin6_addr, host, sizeof(host));
    return fmt::format("[{}]:{}", host, ntohs(in6.sin6_port));
  }
  return host;
}

struct Client {
  int id = 0;
  int fd = -1;
  std::string peer;
  std::vector<uint8_t> in;   // received, not yet a complete message
  bool have_header = false;  // `header` is read; `in` holds its body so far
  Header header;
  Clock::time_point last_byte;
  struct Queued {
    Packed message;
    size_t written = 0;  // bytes of it sent
    int stream = -1;     // a Stream, or -1 for a reply
  };
  std::deque<Queued> out;
  size_t out_bytes = 0;                      // still to write
  std::array<int, kStreams> streamed_out{};  // queued messages of each stream
  bool gone = false;
};

// What a client left unfinished, for the line that says why it was dropped.
std::string unfinished(const Client& c) {
  if (!c.have_header)
    return fmt::format("{} of the {} bytes of a header", c.in.size(), kHeaderBytes);
  return fmt::format("{} of the {} body bytes of a {} '{}'", c.in.size(), c.header.body_bytes,
                     c.header.type, c.header.device);
}

}  // namespace

struct Server::State {
  ServerOptions options;
  int listen_fd = -1;
  int port = 0;
  int next_id = 1;
  std::vector<std::unique_ptr<Client>> clients;
  ServerCounters counters;

  void close_client(Client& c) {
    if (c.fd >= 0) ::close(c.fd);
    c.fd = -1;
    c.gone = true;
  }

  // A client that went away between two messages: its own business, not a problem.
  void left(Client& c, const char* how) {
    log::info("OpenIGTLink client {} disconnected{}", c.peer, how);
    close_client(c);
  }

  void drop(Client& c, const std::string& problem) {
    if (c.gone) return;
    log::warn("OpenIGTLink client {}: {}; connection dropped", c.peer, problem);
    ++counters.dropped;
    close_client(c);
  }

  void accept_all() {
    for (;;) {
      sockaddr_storage addr{};
      socklen_t len = sizeof(addr);
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&addr), &len,
                               SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK)
          log::warn("OpenIGTLink: accepting a connection failed: {}", std::strerror(errno));
        return;
      }
      const std::string peer = address_name(addr);
      if (static_cast<int>(clients.size()) >= options.max_clients) {
        log::warn(
            "OpenIGTLink client {}: refused, {} clients are connected already; connection "
            "dropped",
            peer, clients.size());
        ++counters.dropped;
        ::close(fd);
        continue;
      }
      // Poses and small replies go out at once instead of waiting to fill a segment.
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      auto c = std::make_unique<Client>();
      c->id = next_id++;
      c->fd = fd;
      c->peer = peer;
      c->last_byte = Clock::now();
      log::info("OpenIGTLink client {} connected", peer);
      ++counters.clients;
      clients.push_back(std::move(c));
    }
  }

  // Hands over every complete message in c.in; a problem drops the client.
  void consume(Client& c, const Handler& handle) {
    size_t pos = 0;
    try {
      for (;;) {
        if (!c.have_header) {
          if (c.in.size() - pos < kHeaderBytes) break;
          c.header = read_header(c.in.data() + pos, options.max_body_bytes);
          c.have_header = true;
          pos += kHeaderBytes;
        }
        if (c.in.size() - pos < c.header.body_bytes) break;
        const uint8_t* body = c.in.data() + pos;
        const Content content = check_body(c.header, body);
        ++counters.messages_in;
        handle(Message{c.id, c.peer, c.header, body + content.offset, content.size});
        pos += static_cast<size_t>(c.header.body_bytes);
        c.have_header = false;
        if (c.gone) return;
      }
    } catch (const Error& e) {
      drop(c, e.what());
      return;
    } catch (const std::exception& e) {
      drop(c, std::string("internal error on its message: ") + e.what());
      return;
    }
    c.in.erase(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(pos));
  }

  void read_from(Client& c, const Handler& handle) {
    uint8_t buffer[1 << 16];
    // At most 1 MB per poll, so that a flooding client cannot starve the others.
    for (size_t budget = 1 << 20; budget > 0 && !c.gone;) {
      const ssize_t n = ::recv(c.fd, buffer, sizeof(buffer), MSG_DONTWAIT);
      if (n > 0) {
        c.in.insert(c.in.end(), buffer, buffer + n);
        c.last_byte = Clock::now();
        budget -= std::min(budget, static_cast<size_t>(n));
        consume(c, handle);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      const bool midway = c.have_header || !c.in.empty();
      if (!midway && (n == 0 || errno == ECONNRESET)) {
        left(c, n == 0 ? "" : " (connection reset)");
      } else if (n == 0) {
        drop(c, "closed the connection in the middle of a message, after " + unfinished(c));
      } else {
        drop(c, std::string("the connection failed: ") + std::strerror(errno) +
                    (midway ? ", after " + unfinished(c) : ""));
      }
      return;
    }
  }

  void write_to(Client& c) {
    while (!c.out.empty() && !c.gone) {
      auto& [message, written, stream] = c.out.front();
      const ssize_t n = ::send(c.fd, message->data() + written, message->size() - written,
                               MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        written += static_cast<size_t>(n);
        c.out_bytes -= static_cast<size_t>(n);
        if (written == message->size()) {
          if (stream >= 0) --c.streamed_out[static_cast<size_t>(stream)];
          c.out.pop_front();
        }
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if ((errno == EPIPE || errno == ECONNRESET) && !c.have_header && c.in.empty())
        left(c, " (while being sent to)");
      else
        drop(c, std::string("sending failed: ") + std::strerror(errno));
    }
  }

  void queue(Client& c, const Packed& message, int stream = -1) {
    if (c.gone) return;
    c.out.push_back({message, 0, stream});
    if (stream >= 0) ++c.streamed_out[static_cast<size_t>(stream)];
    c.out_bytes += message->size();
    ++counters.messages_out;
    counters.bytes_out += static_cast<int64_t>(message->size());
    if (c.out_bytes > options.max_backlog_bytes)
      drop(c, fmt::format("does not read what it asked for ({} bytes queued)", c.out_bytes));
    else
      write_to(c);
  }
};

Server::Server(const ServerOptions& options) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.options = options;
  if (options.port < 0 || options.port > 65535)
    throw invalid_input("--port", "must be 0..65535, got " + std::to_string(options.port));
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(options.port);
  if (const int r = ::getaddrinfo(options.host.c_str(), port.c_str(), &hints, &found); r != 0)
    throw invalid_input("--host", options.host + ": " + ::gai_strerror(r));
  std::string problem = "no address";
  for (addrinfo* a = found; a && s.listen_fd < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) continue;
    // A restarted server can listen again at once on the port its last run used.
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 16) == 0) {
      s.listen_fd = fd;
    } else {
      problem = errno == EADDRINUSE
                    ? "in use (another server listens there; pick another port with --port)"
                    : std::strerror(errno);
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  if (s.listen_fd < 0)
    throw invalid_input("--port", options.host + ":" + port + ": cannot listen: " + problem);
  sockaddr_storage bound{};
  socklen_t len = sizeof(bound);
  ::getsockname(s.listen_fd, reinterpret_cast<sockaddr*>(&bound), &len);
  s.port = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6&>(bound).sin6_port
                                             : reinterpret_cast<sockaddr_in&>(bound).sin_port);
}

Server::~Server() {
  for (auto& c : state_->clients) state_->close_client(*c);
  if (state_->listen_fd >= 0) ::close(state_->listen_fd);
}

int Server::port() const {
  return state_->port;
}

int Server::client_count() const {
  return static_cast<int>(state_->clients.size());
}

const ServerCounters& Server::counters() const {
  return state_->counters;
}

void Server::poll(double timeout_s, const Handler& handle, const Closed& closed) {
  State& s = *state_;
  // Wake up in time to drop a client stalled in the middle of a message.
  const auto now = Clock::now();
  double wait_s = std::max(timeout_s, 0.0);
  for (const auto& c : s.clients)
    if (c->have_header || !c->in.empty())
      wait_s = std::min(wait_s, s.options.stall_timeout_s -
                                    std::chrono::duration<double>(now - c->last_byte).count());
  std::vector<pollfd> fds;
  fds.push_back({s.listen_fd, POLLIN, 0});
  for (const auto& c : s.clients)
    fds.push_back({c->fd, static_cast<short>(POLLIN | (c->out_bytes > 0 ? POLLOUT : 0)), 0});
  const int ready =
      ::poll(fds.data(), fds.size(), static_cast<int>(std::ceil(std::max(wait_s, 0.0) * 1000.0)));
  if (ready > 0) {
    // Clients first: the ones accepted now are not in `fds` yet.
    for (size_t i = 1; i < fds.size(); ++i) {
      Client& c = *s.clients[i - 1];
      if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) s.read_from(c, handle);
      if (!c.gone && (fds[i].revents & POLLOUT)) s.write_to(c);
    }
    if (fds[0].revents & POLLIN) s.accept_all();
  }
  const auto later = Clock::now();
  for (auto& c : s.clients) {
    const double silent_s = std::chrono::duration<double>(later - c->last_byte).count();
    if (!c->gone && (c->have_header || !c->in.empty()) && silent_s >= s.options.stall_timeout_s)
      s.drop(*c, fmt::format("sent {} and then nothing for {:.1f} s (--stall-timeout)",
                             unfinished(*c), silent_s));
  }
  for (auto& c : s.clients)
    if (c->gone && closed) closed(c->id);
  std::erase_if(s.clients, [](const auto& c) { return c->gone; });
}

void Server::send(int client, const Packed& message) {
  for (auto& c : state_->clients)
    if (c->id == client) state_->queue(*c, message);
}

void Server::broadcast(const Packed& message) {
  for (auto& c : state_->clients)
    if (!c->gone) state_->queue(*c, message);
}

void Server::stream(const std::vector<Packed>& batch, Stream stream) {
  const auto s = static_cast<size_t>(stream);
  for (auto& c : state_->clients) {
    if (c->gone) continue;
    if (c->streamed_out[s] > 0) {
      ++state_->counters.frames_skipped;
      continue;
    }
    for (const Packed& m : batch) state_->queue(*c, m, static_cast<int>(s));
  }
}

}  // namespace lamina::net::igtlink
