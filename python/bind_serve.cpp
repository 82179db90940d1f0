// Serving from Python (lamina::net, include/lamina/net/serve.h): Simulation.serve and
// World.serve take `lamina serve`'s options as keywords and run the serve on this thread with
// the GIL released; Ctrl-C (Python's signal handler) ends it as it ends the command.
#include <pybind11/stl.h>

#include <functional>
#include <map>
#include <string>

#include "bindings.h"
#include "lamina/net/serve.h"

namespace lamina::python {
namespace py = pybind11;

namespace {

// Each keyword and the field it sets: the options' names as Python spells them.
using Setter = std::function<void(net::ServeOptions&, const py::handle&)>;

template <class T>
Setter set(T net::ServeOptions::*field) {
  return [field](net::ServeOptions& o, const py::handle& v) { o.*field = v.cast<T>(); };
}

const std::map<std::string, Setter>& setters() {
  using O = net::ServeOptions;
  static const std::map<std::string, Setter> table = {
      {"host", set(&O::host)},
      {"port", set(&O::port)},
      {"send_hz", set(&O::send_hz)},
      {"embedded_hz", set(&O::embedded_hz)},
      {"reaction_hz", set(&O::reaction_hz)},
      {"all_layers", set(&O::all_layers)},
      {"rate_hz", set(&O::rate_hz)},
      {"auto_rate", set(&O::auto_rate)},
      {"duration_s", set(&O::duration_s)},
      {"frame", set(&O::frame)},
      {"tool_device", set(&O::tool_device)},
      {"grasper_device", set(&O::grasper_device)},
      {"grasper_radius_mm", set(&O::grasper_radius_mm)},
      {"scalpel_device", set(&O::scalpel_device)},
      {"scalpel_depth_mm", set(&O::scalpel_depth_mm)},
      {"scalpel_pause_s", set(&O::scalpel_pause_s)},
      {"tip_radius_mm", set(&O::tip_radius_mm)},
      {"tip_stiffness_n_per_m", set(&O::tip_stiffness_n_per_m)},
      {"max_force_n", set(&O::max_force_n)},
      {"max_message_mb", set(&O::max_message_mb)},
      {"stall_timeout_s", set(&O::stall_timeout_s)},
      {"max_clients", set(&O::max_clients)},
      {"threads", set(&O::threads)},
      {"web", set(&O::web)},
      {"web_host", set(&O::web_host)},
      {"web_port", set(&O::web_port)},
      {"web_hz", set(&O::web_hz)},
      {"web_token", set(&O::web_token)},
      {"web_root", set(&O::web_root)},
      {"self_signed", set(&O::self_signed)},
      {"cert", set(&O::cert)},
      {"key", set(&O::key)},
      {"gain_n_per_mm", set(&O::gain_n_per_mm)},
  };
  return table;
}

}  // namespace

net::ServeOptions serve_options(const py::kwargs& kwargs) {
  net::ServeOptions o;
  for (const auto& [key, value] : kwargs) {
    const std::string name = py::str(key);
    const auto it = setters().find(name);
    if (it == setters().end())
      throw invalid_input("serve: " + name,
                          "is not an option of serve (docs/python.md lists them: port, web, "
                          "web_port, duration_s, rate_hz, ...)");
    try {
      it->second(o, value);
    } catch (const py::cast_error&) {
      throw invalid_input("serve: " + name,
                          "is " + std::string(py::str(py::type::of(value).attr("__name__"))) +
                              ", which this option cannot take");
    }
  }
  net::check_options(o);
  return o;
}

int serve_until_interrupted(const std::function<int(const net::KeepGoing&)>& serve) {
  bool interrupted = false;
  const net::KeepGoing keep_going = [&interrupted] {
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) interrupted = true;  // Ctrl-C: the error stays set
    return !interrupted;
  };
  int code = 0;
  {
    py::gil_scoped_release released;
    code = serve(keep_going);
  }
  if (interrupted) throw py::error_already_set();  // KeyboardInterrupt, after the summary
  return code;
}

}  // namespace lamina::python
