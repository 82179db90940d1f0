#pragma once
// What a net::Listening holds (include/lamina/net/serve.h): the servers it opened, which
// serve_organ and serve_world take over; and the web sessions' options both kinds of serve
// share.
#include <memory>

#include "igtl_server.h"
#include "lamina/net/serve.h"
#include "web_server.h"
#include "web_session.h"

namespace lamina::net {

struct Listening::Servers {
  std::unique_ptr<igtlink::Server> igtl;  ///< null when listened without it
  std::unique_ptr<web::Server> web;       ///< null without options.web
};

/// The web sessions' options from the serve's (the one-organ session's and the world's): frame
/// rate, drag gain, and the hello's fields (the tools' limits, the frame rate).
web::SessionOptions web_session_options(const ServeOptions& o);

}  // namespace lamina::net
