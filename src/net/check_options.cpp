// The serve's options checked before anything listens (include/lamina/net/serve.h); each error
// names the option as `lamina serve` spells it.
#include <cctype>
#include <string>

#include "lamina/core/error.h"
#include "lamina/net/serve.h"

namespace lamina::net {

void check_options(const ServeOptions& a) {
  if (!(a.send_hz >= 0.0 && a.send_hz <= 1000.0))
    throw invalid_input("--send-hz", "must be in [0, 1000] messages per second");
  if (!(a.embedded_hz >= 0.0 && a.embedded_hz <= 1000.0))
    throw invalid_input("--embedded-hz", "must be in [0, 1000] messages per second");
  if (!(a.reaction_hz >= 0.0 && a.reaction_hz <= 1e5))
    throw invalid_input("--reaction-hz", "must be in [0, 1e5] messages per second");
  if (!(a.rate_hz > 0.0 && a.rate_hz <= 1e5))
    throw invalid_input("--rate", "must be in (0, 1e5] steps per second");
  if (!(a.duration_s >= 0.0)) throw invalid_input("--duration", "must be >= 0 s");
  if (a.frame != "ras" && a.frame != "lps")
    throw invalid_input("--frame", "must be ras or lps, got '" + a.frame + "'");
  if (!a.grasper_device.empty() && a.grasper_device == a.tool_device)
    throw invalid_input("--grasper-device",
                        "is also --tool-device ('" + a.tool_device + "'): give them two names");
  if (!(a.grasper_radius_mm > 0.0 && a.grasper_radius_mm <= 100.0))
    throw invalid_input("--grasper-radius", "must be in (0, 100] mm");
  for (const std::string* other : {&a.tool_device, &a.grasper_device})
    if (!a.scalpel_device.empty() && a.scalpel_device == *other)
      throw invalid_input("--scalpel-device", "is also the tool's or the grasper's device ('" +
                                                  a.scalpel_device + "'): give each its own name");
  if (!(a.scalpel_depth_mm > 0.0 && a.scalpel_depth_mm <= 200.0))
    throw invalid_input("--scalpel-depth", "must be in (0, 200] mm");
  if (!(a.scalpel_pause_s > 0.0 && a.scalpel_pause_s <= 60.0))
    throw invalid_input("--scalpel-pause", "must be in (0, 60] s");
  if (!(a.tip_radius_mm > 0.0 && a.tip_radius_mm <= 100.0))
    throw invalid_input("--tip-radius", "must be in (0, 100] mm");
  if (!(a.tip_stiffness_n_per_m > 0.0 && a.tip_stiffness_n_per_m <= 1e4))
    throw invalid_input("--tip-stiffness", "must be in (0, 1e4] N/m");
  if (!(a.max_force_n > 0.0 && a.max_force_n <= 100.0))
    throw invalid_input("--max-force", "must be in (0, 100] N (what a haptic device is sent)");
  if (!(a.max_message_mb > 0.0 && a.max_message_mb <= 1024.0))
    throw invalid_input("--max-message-mb", "must be in (0, 1024] MB");
  if (!(a.stall_timeout_s > 0.0)) throw invalid_input("--stall-timeout", "must be > 0 s");
  if (a.max_clients < 1) throw invalid_input("--max-clients", "must be >= 1");
  if (a.threads < 0) throw invalid_input("--threads", "must be >= 0 (0 = OpenMP's default)");
  if (!(a.web_hz > 0.0 && a.web_hz <= 240.0))
    throw invalid_input("--web-hz", "must be in (0, 240] frames per second");
  if (a.web_port < 0 || a.web_port > 65535)
    throw invalid_input("--web-port", "must be in [0, 65535]");
  if (!(a.gain_n_per_mm > 0.0 && a.gain_n_per_mm <= 1.0))
    throw invalid_input("--gain", "must be in (0, 1] N/mm");
  if (a.self_signed && (!a.cert.empty() || !a.key.empty()))
    throw invalid_input("--self-signed", "give either --self-signed or --cert and --key");
  if (a.cert.empty() != a.key.empty())
    throw invalid_input(a.cert.empty() ? "--key" : "--cert", "needs the other: --cert and --key");
  if ((a.self_signed || !a.cert.empty()) && !a.web)
    throw invalid_input(a.self_signed ? "--self-signed" : "--cert",
                        "is for the web server: add --web");
  for (const char c : a.web_token)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_')
      throw invalid_input("--token", "may hold letters, digits, '-' and '_' only");
}

}  // namespace lamina::net
