// Rendering benchmarks, headless (EGL surfaceless, Mesa's llvmpipe on this machine): one frame of
// the paper-size phantom drawn into a multisampled framebuffer and read back, at the viewer's
// and the figures' sizes; and the CPU share of a frame (normals and colours) alone.
#include <benchmark/benchmark.h>

#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/render/camera.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"

namespace {

using namespace lamina;

const Model& phantom_model() {
  static const Model m = model::build_model(geometry::make_phantom(), {}).model;
  return m;
}

render::Renderer& renderer() {
  static render::HeadlessContext context;
  static render::Renderer r;
  return r;
}

void BM_RenderImage(benchmark::State& state) {
  const Model& m = phantom_model();
  render::Frame f;
  f.model = &m;
  f.rings.push_back({0, 4});
  const render::Camera cam = render::fit_camera(m);
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  for (auto _ : state) {
    render::Image img = render::render_image(renderer(), f, cam, w, h);
    benchmark::DoNotOptimize(img.rgba.data());
  }
  state.counters["pixels"] = static_cast<double>(w) * h;
}
BENCHMARK(BM_RenderImage)->Args({640, 480})->Args({1400, 900})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
