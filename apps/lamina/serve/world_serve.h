#pragma once
// `lamina serve` of a world scene (world_serve.cpp): served to the web page only; and the web
// sessions' options both kinds of serve share.
#include <atomic>
#include <memory>

#include "commands.h"
#include "web_server.h"
#include "web_session.h"

namespace lamina::cli {

/// The web sessions' options from the command line (the one-organ session's and the world's):
/// frame rate, drag gain, and the hello's fields (the tools' limits, the frame rate).
web::SessionOptions web_session_options(const ServeArgs& a);

/// Builds the world of `a.what` (a world scene), steps it in real time (world::WorldLoop) and
/// serves it on `web_server` (already listening) until `stop` or --duration.
/// @return 0, or ErrorKind::kUnstable's code when a body became unstable
int run_world_serve(const ServeArgs& a, std::unique_ptr<web::Server> web_server,
                    const std::atomic<bool>& stop);

}  // namespace lamina::cli
