// Model-building benchmarks: the paper-size model and a clinical-size mask (512x512x130 at
// 0.6x0.6x1.6 mm, the phantom resampled). File reading is excluded: the volume is made in
// memory before timing. Every benchmark reports the process's peak resident memory.
#include <benchmark/benchmark.h>

#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/model/build_model.h"
#include "lamina/model/compute_rings.h"
#include "peak_rss.h"

namespace {

using namespace lamina;

using bench::peak_rss_mb;

// With its anatomy as labels (the organ is their union: the same voxels as without).
const LabelVolume& clinical_mask() {
  static const LabelVolume v = geometry::make_phantom(
      {.spacing_mm = {0.6, 0.6, 1.6}, .size = {512, 512, 130}, .anatomy = true});
  return v;
}

// The simulation's model alone, without the display skin (measured on its own below).
model::BuildOptions plain(int32_t layers = 2, int32_t skin_vertices = 1284) {
  model::BuildOptions o;
  o.layers = layers;
  o.skin_vertices = skin_vertices;
  o.display_triangles = 0;
  return o;
}

const LabelVolume& paper_mask() {
  static const LabelVolume v = geometry::make_phantom();
  return v;
}

void report(benchmark::State& state, const model::BuildResult& r, const LabelVolume& v) {
  state.counters["voxels"] = static_cast<double>(v.frame.voxel_count());
  state.counters["nodes"] = r.model.node_count();
  state.counters["springs"] = static_cast<double>(r.model.springs.size());
  state.counters["peak_rss_mb"] = peak_rss_mb();
}

void BM_BuildPaperSize(benchmark::State& state) {
  const LabelVolume& v = paper_mask();
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, plain());
  report(state, r, v);
}
BENCHMARK(BM_BuildPaperSize)->Unit(benchmark::kMillisecond)->Iterations(3)->Repetitions(3);

void BM_BuildClinicalMask(benchmark::State& state) {
  const LabelVolume& v = clinical_mask();
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, plain(static_cast<int32_t>(state.range(0))));
  report(state, r, v);
}
BENCHMARK(BM_BuildClinicalMask)
    ->Arg(2)
    ->Arg(4)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->Repetitions(3);

void BM_BuildClinicalMaskFine(benchmark::State& state) {
  // A 20k-vertex skin: the remesher works at the input's own resolution.
  const LabelVolume& v = clinical_mask();
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, plain(2, 20000));
  report(state, r, v);
}
BENCHMARK(BM_BuildClinicalMaskFine)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

// Issue 33: the default display skin (100k triangles) and the vessel tree and tumour embedded,
// against BM_BuildClinicalMask/2 (the target: at most 3 s more).
void BM_BuildClinicalMaskWithAnatomy(benchmark::State& state) {
  const LabelVolume& v = clinical_mask();
  model::BuildOptions o;
  o.embed = {{.name = "vessels", .label = geometry::kPhantomVessel},
             {.name = "tumour", .label = geometry::kPhantomTumour}};
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, o);
  report(state, r, v);
  int64_t triangles = 0;
  for (const EmbeddedSurface& e : r.model.embedded) triangles += e.F.rows();
  state.counters["embedded_triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_BuildClinicalMaskWithAnatomy)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

// Issue 46: the carved-out layout on the clinical grid (each voxel liver or a structure, the portal
// trunk and the vena cava leaving the organ), the organ's label with three structures embedded
// (portal vein, hepatic veins, tumours) and the default display skin; against
// BM_BuildClinicalMaskWithDisplaySkin (the target: <= 4 s against <= 2 s).
void BM_BuildClinicalCarvedOutThreeStructures(benchmark::State& state) {
  static const LabelVolume v = geometry::make_phantom(
      {.spacing_mm = {0.6, 0.6, 1.6}, .size = {512, 512, 130}, .carved_out = true});
  model::BuildOptions o;
  o.label = geometry::kPhantomLiver;
  o.embed = {{.name = "portal vein", .label = geometry::kPhantomVessel},
             {.name = "hepatic veins", .label = geometry::kPhantomHepaticVeins},
             {.name = "tumours", .label = geometry::kPhantomTumour}};
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, o);
  report(state, r, v);
}
BENCHMARK(BM_BuildClinicalCarvedOutThreeStructures)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

void BM_BuildClinicalMaskWithDisplaySkin(benchmark::State& state) {
  const LabelVolume& v = clinical_mask();
  model::BuildResult r;
  for (auto _ : state) r = model::build_model(v, model::BuildOptions{});
  report(state, r, v);
}
BENCHMARK(BM_BuildClinicalMaskWithDisplaySkin)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

void BM_SignedDistanceClinical(benchmark::State& state) {
  const Mask m = geometry::prepare_mask(clinical_mask()).mask;
  for (auto _ : state) benchmark::DoNotOptimize(geometry::signed_distance(m));
  state.counters["voxels"] = static_cast<double>(m.frame.voxel_count());
  state.counters["peak_rss_mb"] = peak_rss_mb();
}
BENCHMARK(BM_SignedDistanceClinical)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

void BM_ComputeRings(benchmark::State& state) {
  static const model::BuildResult b = model::build_model(paper_mask(), {});
  for (auto _ : state)
    benchmark::DoNotOptimize(model::compute_rings(b.model, static_cast<int32_t>(state.range(0))));
  state.counters["nodes"] = b.model.node_count();
}
BENCHMARK(BM_ComputeRings)->Arg(4)->Arg(8)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
