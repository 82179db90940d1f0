// What `lamina serve --web` costs a frame (docs/web.md, docs/benchmarks.md): the stream's
// encoding (W x when carried by vertices, 16-bit quantization, meshoptimizer's vertex codec) and
// the decoding a page does, at the size (a 100k-triangle display skin and three 20k
// structures) on the paper-size model, deformed as a press deforms it. Counters: the frame's
// bytes and, for reference, what the same shape costs uncompressed and by drawn vertices.
#include <benchmark/benchmark.h>

#include <cmath>

#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "peak_rss.h"
#include "web_stream.h"

namespace {

using lamina::Model;

const std::shared_ptr<const Model>& clinical_anatomy() {
  static const std::shared_ptr<const Model> m = [] {
    lamina::model::BuildOptions o;
    o.skin_vertices = 1284;  // the paper's skin
    o.display_triangles = 100000;
    o.structure_triangles = 20000;
    o.embed = {{.name = "portal_vein", .label = lamina::geometry::kPhantomVessel},
               {.name = "tumour", .label = lamina::geometry::kPhantomTumour},
               {.name = "hepatic_veins", .label = lamina::geometry::kPhantomHepaticVeins}};
    return std::make_shared<const Model>(
        lamina::model::build_model(
            lamina::geometry::make_phantom({.spacing_mm = {1.0, 1.0, 1.0}, .carved_out = true}), o)
            .model);
  }();
  return m;
}

// The rest shape with a 20 mm-wide dent 8 mm deep at the organ's +x end, where a tool presses.
Eigen::MatrixX3d pressed(const Model& m) {
  Eigen::MatrixX3d x = m.X;
  const Eigen::Index far = [&] {
    Eigen::Index i = 0;
    m.X.col(0).maxCoeff(&i);
    return i;
  }();
  const Eigen::Vector3d c = m.X.row(far).transpose();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const double d = (m.X.row(i).transpose() - c).norm();
    x(i, 0) -= 8.0 * std::exp(-d * d / (2.0 * 10.0 * 10.0));
  }
  return x;
}

// Arg: 0 carried by nodes (what the server chooses here), 1 by the drawn vertices.
void BM_WebFrameEncode(benchmark::State& state) {
  const auto& m = clinical_anatomy();
  lamina::net::web::WebStream stream(
      m, {},
      state.range(0) == 0 ? lamina::net::web::Carry::kNodes : lamina::net::web::Carry::kVertices);
  const Eigen::MatrixX3d x = pressed(*m);
  lamina::net::web::FrameInfo info;
  size_t bytes = 0;
  for (auto _ : state) {
    const std::string& f = stream.frame(x, info);
    bytes = f.size();
    benchmark::DoNotOptimize(f.data());
  }
  state.counters["frame_kB"] = static_cast<double>(bytes) / 1e3;
  state.counters["points"] = static_cast<double>(stream.streamed_points());
  state.counters["by_nodes"] = stream.by_nodes();
  state.counters["drawn_vertices"] = static_cast<double>(stream.drawn_vertices());
  state.counters["drawn_triangles"] = static_cast<double>(stream.drawn_triangles());
  // Uncompressed 16-bit positions of the drawn vertices: what carrying them would cost.
  state.counters["raw_vertices_kB"] = static_cast<double>(stream.drawn_vertices() * 6) / 1e3;
  size_t setup = 0;
  for (const std::string& s : stream.setup()) setup += s.size();
  state.counters["setup_kB"] = static_cast<double>(setup) / 1e3;
  state.counters["peak_rss_MB"] = lamina::bench::peak_rss_mb();
}
BENCHMARK(BM_WebFrameEncode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_WebFrameDecode(benchmark::State& state) {
  const auto& m = clinical_anatomy();
  lamina::net::web::WebStream stream(
      m, {},
      state.range(0) == 0 ? lamina::net::web::Carry::kNodes : lamina::net::web::Carry::kVertices);
  const std::vector<uint16_t> rest = lamina::net::web::decode_rest(stream.setup().back());
  const std::string frame = stream.frame(pressed(*m), {});
  for (auto _ : state) {
    std::vector<uint16_t> q = lamina::net::web::decode_frame(frame, rest);
    benchmark::DoNotOptimize(q.data());
  }
  state.counters["peak_rss_MB"] = lamina::bench::peak_rss_mb();
}
BENCHMARK(BM_WebFrameDecode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
