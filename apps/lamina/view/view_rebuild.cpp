// The Model panel's rebuild: the new model is built on a worker thread while the old one keeps
// running, then swapped in between two frames: the simulation thread is stopped (it points into
// the old model), the engine is given the new model under the same name, and a new simulation
// starts on it.
#include <fmt/format.h>

#include "view_session_state.h"

namespace lamina::cli {

void ViewSession::State::start_rebuild() {
  if (rebuilding || !options.rebuild) return;
  if (rebuild_thread.joinable()) rebuild_thread.join();
  rebuilding = true;
  rebuild_error.clear();
  rebuild_thread = std::thread([this, layers = rebuild_layers, verts = rebuild_vertices] {
    try {
      auto progress = [this](std::string_view stage, double fraction) {
        std::lock_guard lock(rebuild_mutex);
        rebuild_stage = std::string(stage);
        rebuild_fraction = fraction;
      };
      auto result = std::make_unique<ViewModel>(options.rebuild(layers, verts, progress));
      std::lock_guard lock(rebuild_mutex);
      rebuilt = std::move(result);
    } catch (const std::exception& e) {
      std::lock_guard lock(rebuild_mutex);
      rebuild_error = e.what();
    }
    rebuilding = false;
  });
}

bool ViewSession::State::rebuild_pending() {
  if (rebuilding) return true;
  std::lock_guard lock(rebuild_mutex);
  return rebuilt != nullptr;  // built, not yet in use (adopted at the next frame)
}

void ViewSession::State::adopt_rebuilt() {
  std::unique_ptr<ViewModel> next;
  {
    std::lock_guard lock(rebuild_mutex);
    next = std::move(rebuilt);
  }
  if (!next) return;
  loop->stop();
  loop.reset();  // the loop points into the old model: stop it before replacing the model
  vm = std::move(next);
  render::register_model(kModelName, vm->model);  // replaces the old one, style kept
  // ... but for its embedded surfaces, which are the new model's own.
  style.embedded.clear();
  for (size_t i = 0; i < vm->model.embedded.size(); ++i)
    style.embedded.push_back(render::embedded_look(vm->model, i));
  if (vm->material) material = *vm->material;
  gesture = Gesture::kNone;
  // The last drag's record names nodes of the old model, which mean nothing (or lie outside)
  // in the new one: it ends with the old model.
  last_drag_node = drag_peak_node = -1;
  drag_peak_mm = 0.0;
  released_at_sim_s = settle_3s_mm = -1.0;
  // A new loop has made no cut: the cuts in force are the new model's own (the marks of vessels
  // cut before stay where they were cut; U cannot take those cuts back).
  model_version = 0;
  cuts = 0;
  crossed_before.clear();
  start_loop();
  ++rebuilds;
  status =
      fmt::format("rebuilt: {} nodes, {} layers", vm->model.node_count(), vm->model.layer_count());
}

}  // namespace lamina::cli
