#pragma once
// What the `lamina serve` tests share: child processes (the server, the protocol's example
// clients) with their output in files, and a small OpenIGTLink client on a raw socket that
// packs and unpacks with the OpenIGTLink library, or sends whatever bytes a test wants.

#include <arpa/inet.h>
#include <fcntl.h>
#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_util.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Core>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "support/run_cli.h"
#include "support/test_paths.h"

extern char** environ;

namespace lamina::test {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// A child process with stdout and stderr in files; killed (if still running) when destroyed.
class Child {
 public:
  Child(const std::vector<std::string>& argv, const std::filesystem::path& out,
        const std::filesystem::path& err)
      : out_(out), err_(err) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    if (pid_ < 0) throw std::runtime_error("cannot start " + argv[0]);
  }
  ~Child() {
    if (running()) {
      ::kill(pid_, SIGKILL);
      wait(10.0);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  bool running() {
    if (exit_code_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) != pid_) return true;
    record(status);
    return false;
  }
  /// Waits at most timeout_s for the exit; its code (128 + signal), or nothing if still running.
  std::optional<int> wait(double timeout_s) {
    const auto t0 = Clock::now();
    while (running() && seconds_since(t0) < timeout_s)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return exit_code_;
  }
  void terminate() {
    if (running()) ::kill(pid_, SIGTERM);
  }
  std::string out() const { return read_text(out_); }
  std::string err() const { return read_text(err_); }

 private:
  void record(int status) {
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  pid_t pid_ = -1;
  std::optional<int> exit_code_;
  std::filesystem::path out_, err_;
};

/// `lamina serve ARGS --port 0`, started and waited for until it listens.
class Server {
 public:
  Server(const std::filesystem::path& dir, const std::vector<std::string>& args) {
    std::vector<std::string> argv = {lamina_cli(), "serve"};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.insert(argv.end(), {"--port", "0"});
    child_.emplace(argv, dir / "serve_out.txt", dir / "serve_err.txt");
    // The port is logged once the socket listens, before the model is built.
    static const std::regex kListening(R"(listening on [^ ]+:([0-9]+))");
    const auto t0 = Clock::now();
    std::smatch match;
    while (seconds_since(t0) < 60.0) {
      const std::string log = child_->err();
      if (std::regex_search(log, match, kListening)) {
        port_ = std::stoi(match[1].str());
        return;
      }
      if (!child_->running()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    throw std::runtime_error("lamina serve did not start listening: " + child_->err());
  }
  int port() const { return port_; }
  Child& process() { return *child_; }
  std::string log() const { return child_->err(); }
  /// Whether the log says `text` within `seconds`: the server may log a drop after the client has
  /// already seen the close (beast closes the WebSocket before the read handler runs).
  bool log_shows(const std::string& text, double seconds = 5.0) const {
    const auto t0 = Clock::now();
    while (log().find(text) == std::string::npos) {
      if (seconds_since(t0) > seconds) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return true;
  }

 private:
  std::optional<Child> child_;
  int port_ = 0;
};

/// A port someone else listens on (127.0.0.1), for the tests of a port in use; closed when done.
class BusyPort {
 public:
  BusyPort() {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 || ::listen(fd_, 1) != 0)
      throw std::runtime_error("cannot listen on a free port");
    socklen_t len = sizeof(a);
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
  }
  ~BusyPort() { ::close(fd_); }
  BusyPort(const BusyPort&) = delete;
  BusyPort& operator=(const BusyPort&) = delete;
  std::string port() const { return std::to_string(port_); }

 private:
  int fd_ = -1;
  int port_ = 0;
};

/// The numbers of the server's exit summary line.
struct Summary {
  int64_t steps = 0, clients = 0, messages_in = 0, poses = 0, messages_out = 0, dropped = 0;
  double simulated_s = 0.0, wall_s = 0.0, real_time_factor = 0.0, max_reaction_mn = 0.0;
  int64_t lock_waits = 0;           ///< counted by the simulation's thread
  double longest_lock_wait_ms = 0;  ///< the longest a step waited for the server's thread
};

inline std::optional<Summary> parse_summary(const std::string& log) {
  static const std::regex kLine(
      R"(lamina serve: ([0-9]+) steps, ([0-9.]+) s simulated in ([0-9.]+) s \(([0-9.]+)x real )"
      R"(time.*\); ([0-9]+) clients, ([0-9]+) messages in \(([0-9]+) poses\), ([0-9]+) out .*, )"
      R"(([0-9]+) connections dropped; max reaction ([0-9.e+-]+) mN; steps waited for the )"
      R"(server ([0-9]+) times, at most ([0-9.]+) ms)");
  std::smatch m;
  if (!std::regex_search(log, m, kLine)) return std::nullopt;
  Summary s;
  s.steps = std::stoll(m[1]);
  s.simulated_s = std::stod(m[2]);
  s.wall_s = std::stod(m[3]);
  s.real_time_factor = std::stod(m[4]);
  s.clients = std::stoll(m[5]);
  s.messages_in = std::stoll(m[6]);
  s.poses = std::stoll(m[7]);
  s.messages_out = std::stoll(m[8]);
  s.dropped = std::stoll(m[9]);
  s.max_reaction_mn = std::stod(m[10]);
  s.lock_waits = std::stoll(m[11]);
  s.longest_lock_wait_ms = std::stod(m[12]);
  return s;
}

/// A message as received: its header fields and its whole body.
struct Received {
  std::string type, device;
  std::vector<uint8_t> header, body;
};

/// A TCP client of the server, with the OpenIGTLink library for packing and unpacking.
class Client {
 public:
  explicit Client(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0)
      throw std::runtime_error("cannot connect to port " + std::to_string(port));
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    socklen_t len = sizeof(a);
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    local_port_ = ntohs(a.sin_port);
  }
  ~Client() { close(); }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// "127.0.0.1:PORT", as the server names this client in its log.
  std::string peer() const { return "127.0.0.1:" + std::to_string(local_port_); }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  /// Ends the sending side (FIN): the server reads the end of the stream. (A close() with the
  /// server's streamed frames unread would reset the connection instead, a different case.)
  void hang_up() { ::shutdown(fd_, SHUT_WR); }

  void send_bytes(const std::vector<uint8_t>& bytes) {
    ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  void send(igtl::MessageBase& message) {
    message.Pack();
    const auto* p = static_cast<const uint8_t*>(message.GetPackPointer());
    send_bytes(std::vector<uint8_t>(p, p + message.GetPackSize()));
  }

  /// The next whole message, or nothing if none arrives within timeout_s or the server closes.
  /// A message cut by the timeout stays buffered for the next call.
  std::optional<Received> receive(double timeout_s) {
    const auto t0 = Clock::now();
    for (;;) {
      if (pending_.size() >= IGTL_HEADER_SIZE) {
        igtl_header h;
        std::memcpy(&h, pending_.data(), IGTL_HEADER_SIZE);
        igtl_header_convert_byte_order(&h);
        if (h.body_size > (64u << 20)) throw std::runtime_error("out of step with the server");
        const size_t whole = IGTL_HEADER_SIZE + static_cast<size_t>(h.body_size);
        if (pending_.size() >= whole) {
          Received r;
          r.type.assign(h.name, strnlen(h.name, IGTL_HEADER_TYPE_SIZE));
          r.device.assign(h.device_name, strnlen(h.device_name, IGTL_HEADER_NAME_SIZE));
          r.header.assign(pending_.begin(), pending_.begin() + IGTL_HEADER_SIZE);
          r.body.assign(pending_.begin() + IGTL_HEADER_SIZE, pending_.begin() + whole);
          pending_.erase(pending_.begin(), pending_.begin() + whole);
          return r;
        }
      }
      const double left = timeout_s - seconds_since(t0);
      if (left <= 0.0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left * 1000.0) + 1) <= 0) continue;
      uint8_t buffer[65536];
      const ssize_t k = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (k <= 0) return std::nullopt;
      pending_.insert(pending_.end(), buffer, buffer + k);
    }
  }
  /// The next message of this type and device, skipping others.
  std::optional<Received> receive(const std::string& type, const std::string& device,
                                  double timeout_s) {
    const auto t0 = Clock::now();
    while (seconds_since(t0) < timeout_s) {
      auto r = receive(timeout_s - seconds_since(t0));
      if (!r) return std::nullopt;
      if (r->type == type && r->device == device) return r;
    }
    return std::nullopt;
  }

  /// The newest message of this type and device: the first within timeout_s, then any sent
  /// behind it (a reader slower than the stream sees the state of now, not a backlog's past).
  std::optional<Received> newest(const std::string& type, const std::string& device,
                                 double timeout_s) {
    std::optional<Received> last = receive(type, device, timeout_s);
    if (!last) return last;
    while (auto next = receive(type, device, 0.002)) last = std::move(next);
    return last;
  }

  /// True if the server closes the connection within timeout_s (what it sends meanwhile is
  /// read and dropped).
  bool closed_by_server(double timeout_s) {
    const auto t0 = Clock::now();
    uint8_t buffer[65536];
    while (seconds_since(t0) < timeout_s) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (n == 0 || (n < 0 && errno == ECONNRESET)) return true;
    }
    return false;
  }

 private:
  std::vector<uint8_t> pending_;  // received, not yet a whole message
  int fd_ = -1;
  int local_port_ = 0;
};

/// Unpacks a received message into the library's message class, checking its CRC.
template <class M>
typename M::Pointer unpack(const Received& r) {
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), r.header.data(), IGTL_HEADER_SIZE);
  header->Unpack();
  typename M::Pointer m = M::New();
  m->SetMessageHeader(header);
  m->AllocatePack();
  std::memcpy(m->GetPackBodyPointer(), r.body.data(), r.body.size());
  if (!(m->Unpack(1) & igtl::MessageHeader::UNPACK_BODY))
    throw std::runtime_error("a " + r.type + " that does not unpack (bad CRC?)");
  return m;
}

/// The points of a POLYDATA, #points by 3.
inline Eigen::MatrixX3d polydata_points(const Received& r) {
  auto m = unpack<igtl::PolyDataMessage>(r);
  igtl::PolyDataPointArray::Pointer points = m->GetPoints();
  Eigen::MatrixX3d P(points->GetNumberOfPoints(), 3);
  for (int i = 0; i < points->GetNumberOfPoints(); ++i) {
    igtlFloat32 p[3];
    points->GetPoint(i, p);
    P.row(i) << p[0], p[1], p[2];
  }
  return P;
}

/// The translation of a TRANSFORM.
inline Eigen::Vector3d transform_translation(const Received& r) {
  auto m = unpack<igtl::TransformMessage>(r);
  float p[3];
  m->GetPosition(p);
  return {p[0], p[1], p[2]};
}

/// A TRANSFORM message with identity rotation and translation `t` (header version 1).
inline std::vector<uint8_t> transform_bytes(const std::string& device, const Eigen::Vector3d& t) {
  igtl::TransformMessage::Pointer m = igtl::TransformMessage::New();
  m->SetDeviceName(device.c_str());
  igtl::Matrix4x4 matrix;
  igtl::IdentityMatrix(matrix);
  for (int i = 0; i < 3; ++i) matrix[i][3] = static_cast<float>(t[i]);
  m->SetMatrix(matrix);
  m->Pack();
  const auto* p = static_cast<const uint8_t*>(m->GetPackPointer());
  return {p, p + m->GetPackSize()};
}

/// A header for `body` written by hand: any version, type and declared size, the true CRC.
inline std::vector<uint8_t> header_bytes(uint16_t version, const std::string& type,
                                         const std::string& device, uint64_t body_size,
                                         const std::vector<uint8_t>& body) {
  igtl_header h{};
  h.version = version;
  std::strncpy(h.name, type.c_str(), IGTL_HEADER_TYPE_SIZE);
  std::strncpy(h.device_name, device.c_str(), IGTL_HEADER_NAME_SIZE);
  h.body_size = body_size;
  h.crc = crc64(const_cast<uint8_t*>(body.data()), body.size(), 0);
  igtl_header_convert_byte_order(&h);
  std::vector<uint8_t> bytes(IGTL_HEADER_SIZE);
  std::memcpy(bytes.data(), &h, IGTL_HEADER_SIZE);
  return bytes;
}

inline std::vector<uint8_t> concat(std::vector<uint8_t> a, const std::vector<uint8_t>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

}  // namespace lamina::test
