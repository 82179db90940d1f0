// The servers of a serve, listening (net::Listening, include/lamina/net/serve.h): OpenIGTLink's
// and the web edge's with its TLS identity.
#include <arpa/inet.h>
#include <dlfcn.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "servers.h"
#include "web_tls.h"

namespace lamina::net {
namespace {

// The addresses a client may reach the web server by: the one it listens on, or for 0.0.0.0
// every IPv4 address of this machine, and its host name.
std::vector<std::string> local_addresses(const std::string& listen) {
  std::vector<std::string> out;
  if (listen != "0.0.0.0") return {listen};
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) == 0 && name[0] != '\0') out.emplace_back(name);
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) == 0) {
    for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
      if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
      char text[INET_ADDRSTRLEN] = {};
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr, text,
                sizeof text);
      out.emplace_back(text);
    }
    freeifaddrs(list);
  }
  return out;
}

// The page's files: --web-root, or web/ beside the lamina binary (the build's), or the
// installed share/lamina/web.
std::string web_root(const ServeOptions& a) {
  namespace fs = std::filesystem;
  std::vector<fs::path> tried;
  if (!a.web_root.empty()) {
    tried.push_back(a.web_root);
  } else {
    // The program's folder (the build tree's lamina), then this library's: a Python script or
    // a C program serving has its own program (python3) elsewhere.
    const fs::path exe = fs::canonical("/proc/self/exe").parent_path();
    tried = {exe / "web", exe.parent_path() / "share" / "lamina" / "web"};
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&check_options), &info) != 0 && info.dli_fname) {
      const fs::path lib = fs::weakly_canonical(info.dli_fname).parent_path();
      tried.push_back(lib.parent_path() / "web");  // build/src/liblamina_net.so: build/web
      tried.push_back(lib.parent_path() / "share" / "lamina" / "web");  // PREFIX/lib
    }
  }
  for (const fs::path& p : tried)
    if (fs::exists(p / "index.html") && fs::exists(p / "vendor" / "three" / "three.module.js"))
      return p.string();
  throw invalid_input(a.web_root.empty() ? "--web" : "--web-root",
                      "the page's files are not at " + tried.front().string() +
                          " (index.html and vendor/three): build with npm present "
                          "(scripts/setup.sh installs it), or give --web-root");
}

// The web edge (--web): its own server beside OpenIGTLink's, with its TLS identity.
std::unique_ptr<web::Server> start_web(const ServeOptions& a) {
  web::ServerOptions wo;
  wo.host = a.web_host;
  wo.port = a.web_port;
  wo.token = a.web_token;
  wo.root = web_root(a);
  wo.max_clients = a.max_clients;
  wo.stall_timeout_s = std::max(a.stall_timeout_s, 2.0);
  if (!a.cert.empty()) {
    wo.tls = web::read_identity(a.cert, a.key);
  } else if (a.self_signed) {
    // Named for this machine and every address a headset may reach it by.
    std::vector<std::string> hosts = {"localhost", "127.0.0.1"};
    for (const std::string& h : local_addresses(a.web_host))
      if (std::find(hosts.begin(), hosts.end(), h) == hosts.end()) hosts.push_back(h);
    wo.tls = web::self_signed_identity(hosts);
  }
  auto server = std::make_unique<web::Server>(wo);
  if (wo.tls)
    log::info("web: TLS with {} (certificate SHA-256 {}){}", wo.tls->source,
              wo.tls->fingerprint_sha256,
              a.self_signed ? "; a browser warns of a certificate it does not know: compare "
                              "the fingerprint, then accept it"
                            : "");
  log::info("web: listening on {}:{}; the page is at {}", a.web_host, server->port(),
            server->url());
  return server;
}

}  // namespace

Listening::Listening(const ServeOptions& a, bool igtl) : servers(std::make_unique<Servers>()) {
  if (igtl) {
    igtlink::ServerOptions so;
    so.host = a.host;
    so.port = a.port;
    so.max_body_bytes = static_cast<uint64_t>(a.max_message_mb * (1 << 20));
    so.stall_timeout_s = a.stall_timeout_s;
    so.max_clients = a.max_clients;
    servers->igtl = std::make_unique<igtlink::Server>(so);
    log::info("listening on {}:{}", a.host, servers->igtl->port());
  }
  if (a.web) servers->web = start_web(a);
}

Listening::~Listening() = default;

int Listening::igtl_port() const {
  return servers && servers->igtl ? servers->igtl->port() : 0;
}

std::string Listening::web_url() const {
  return servers && servers->web ? servers->web->url() : std::string();
}

}  // namespace lamina::net
