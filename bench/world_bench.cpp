// A world of organs from one patient's segmentation (the TotalSegmentator example in tests/data:
// liver and gallbladder from its label volume, the right kidney from its own mask, on one 3 mm
// grid), each the physical default scene's tissue on its posterior support, the liver poked with
// a held 0.4 N, the gallbladder attached to the liver where they touch: one world step, against
// the liver's own step alone measured in the same run. Counters: steps/s, the contact and
// coupling stage's share of the step, nodes, ties, contacts, the deepest rest overlap; every
// benchmark reports the process's peak resident memory.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene.h"
#include "lamina/model/build_model.h"
#include "lamina/world/world.h"
#include "lamina/world/world_loop.h"
#include "peak_rss.h"

namespace {

using namespace lamina;

struct Organ {
  std::string name;
  std::shared_ptr<Model> model;
};

// The three organs at one density: the liver with `liver_skin` skin vertices (1284: the
// paper's size), the gallbladder and the kidney in proportion (400 and 600 at the paper's size).
// Built once per size.
const std::vector<Organ>& organs(int32_t liver_skin = 1284) {
  static std::map<int32_t, std::vector<Organ>> built;
  const auto it = built.find(liver_skin);
  if (it != built.end()) return it->second;
  const std::string data = LAMINA_BENCH_DATA;
  static const LabelVolume labels =
      io::read_label_volume(data + "/liver_totalseg_example_3mm_labels.nii.gz");
  static const LabelVolume kidney =
      io::read_label_volume(data + "/kidney_right_totalseg_example_3mm.nii.gz");
  const auto build = [](const LabelVolume& v, int32_t label, int32_t skin) {
    return std::make_shared<Model>(
        model::build_model(v, {.label = label, .display_triangles = 0, .skin_vertices = skin})
            .model);
  };
  const double f = liver_skin / 1284.0;
  return built[liver_skin] = {
             {"liver", build(labels, 1, liver_skin)},
             {"gallbladder", build(labels, 4, static_cast<int32_t>(std::lround(400 * f)))},
             {"kidney_right", build(kidney, 0, static_cast<int32_t>(std::lround(600 * f)))}};
}

// The default scene's physical tissue on `m`, its posterior surface supported; the poke only on
// the first organ (held on).
world::BodyDef body_of(const Organ& organ, bool poke) {
  io::Scene scene;
  scene.default_tool = poke;
  const io::SceneSetup setup = io::prepare_scene(scene, *organ.model);
  world::BodyDef def{.name = organ.name,
                     .model = organ.model,
                     .simulation = io::make_scene_simulation(scene, *organ.model, setup),
                     .tools = {}};
  def.tools.tools = scene.tools;
  for (interact::Tool& t : def.tools.tools) t.end_s = 1e9;
  def.tools.routing = scene.routing;
  return def;
}

// `bodies` of the organs (the liver poked), the gallbladder attached to the liver.
world::World make_world(int32_t bodies, int32_t liver_skin, std::vector<world::BodyId>& ids) {
  world::World w;
  w.contact.rest_overlap_tolerance_mm = 6.0;  // two voxels: reported below
  for (int32_t b = 0; b < bodies; ++b)
    ids.push_back(
        world::create_body(w, body_of(organs(liver_skin)[static_cast<size_t>(b)], b == 0)));
  if (bodies >= 2)
    world::create_attachment(w, {.body_a = ids[0].index,
                                 .body_b = ids[1].index,
                                 .generation_a = ids[0].generation,
                                 .generation_b = ids[1].generation,
                                 .reach_mm = 3.0});
  return w;
}

void BM_WorldStep(benchmark::State& state) {
  const int32_t bodies = static_cast<int32_t>(state.range(0));
  const auto liver_skin = static_cast<int32_t>(state.range(1));
  std::vector<world::BodyId> ids;
  world::World w = make_world(bodies, liver_skin, ids);
  world::WorldStepStats st;
  for (int k = 0; k < 50; ++k) world::step(w, st);  // into the motion
  double contact_us = 0.0, step_us = 0.0, contacts = 0.0;
  for (auto _ : state) {
    world::step(w, st);
    contact_us += st.profile.contact_us;
    step_us += st.step_us;
    for (const world::BodyStepStats& b : st.bodies) contacts += b.contacts + b.self_contacts;
  }
  const double n = static_cast<double>(state.iterations());
  int64_t nodes = 0;
  double overlap = 0.0;
  for (const world::BodyId id : ids) {
    const world::Body& b = world::body(w, id);
    nodes += b.model->node_count();
    if (!b.rest_overlap_mm.empty())
      overlap =
          std::max(overlap, *std::max_element(b.rest_overlap_mm.begin(), b.rest_overlap_mm.end()));
  }
  state.counters["bodies"] = bodies;
  state.counters["nodes"] = static_cast<double>(nodes);
  state.counters["ties"] = static_cast<double>(world::count_ties(w).total);
  state.counters["contacts"] = contacts / n;
  state.counters["contact_pct"] = 100.0 * contact_us / std::max(step_us, 1e-9);
  state.counters["max_rest_overlap_mm"] = overlap;
  state.counters["unstable"] = st.unstable == sim::Instability::kNone ? 0.0 : 1.0;
  state.counters["steps_per_s"] = benchmark::Counter(n, benchmark::Counter::kIsRate);
  state.counters["peak_rss_mb"] = bench::peak_rss_mb();
}
// At the paper's size, then at the sizes a user picks (about 10k, 40k and 100k nodes in all):
// fewer steps where a step takes longer.
BENCHMARK(BM_WorldStep)
    ->Args({1, 1284})
    ->Args({3, 1284})
    ->ArgNames({"bodies", "liver_skin"})
    ->Iterations(1000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_WorldStep)
    ->Args({3, 5000})
    ->ArgNames({"bodies", "liver_skin"})
    ->Iterations(200)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_WorldStep)
    ->Args({3, 20000})
    ->Args({3, 50000})
    ->ArgNames({"bodies", "liver_skin"})
    ->Iterations(30)
    ->Unit(benchmark::kMillisecond);

// The reference: the liver's own simulation stepped alone, the same poke, at each size.
// The same world of three in a world::WorldLoop, the viewer's and the web page's: one step on
// the caller's thread per iteration (run_steps: the commands taken, the scene's blades advanced,
// the rate window kept, a snapshot published), against BM_WorldStep's bare step.
void BM_WorldLoopRunSteps(benchmark::State& state) {
  std::vector<world::BodyId> ids;
  world::WorldLoop loop(make_world(3, 1284, ids), {.rate_hz = 0.0, .real_time = false});
  loop.run_steps(50);
  for (auto _ : state) loop.run_steps(1);
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["peak_rss_mb"] = bench::peak_rss_mb();
}
BENCHMARK(BM_WorldLoopRunSteps)->Iterations(1000)->Unit(benchmark::kMicrosecond);

// ...and in its own thread as fast as it can go (rate 0), snapshots published at 240 Hz and
// copied by this thread as a viewer does: steps per wall second over 0.5 s an iteration.
void BM_WorldLoopThread(benchmark::State& state) {
  std::vector<world::BodyId> ids;
  world::WorldLoop loop(make_world(3, 1284, ids), {.rate_hz = 0.0, .real_time = false});
  world::WorldSnapshot snap;
  loop.start();
  int64_t steps = 0;
  double seconds = 0.0;
  for (auto _ : state) {
    loop.latest(snap);
    const int64_t s0 = snap.steps;
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(500)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(16));  // a display's frame
      loop.latest(snap);
    }
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(dt);
    steps += snap.steps - s0;
    seconds += dt;
  }
  loop.stop();
  state.counters["steps_per_s"] = static_cast<double>(steps) / seconds;
  state.counters["lock_waits"] = static_cast<double>(snap.lock_waits);
  state.counters["longest_lock_wait_us"] = snap.longest_lock_wait_us;
  state.counters["peak_rss_mb"] = bench::peak_rss_mb();
}
BENCHMARK(BM_WorldLoopThread)->Iterations(4)->UseManualTime()->Unit(benchmark::kMillisecond);

// A stroke through the liver of the running world (the loop in its thread as fast as it goes,
// the cut made on another thread with background_cuts, else on the stepping thread), each
// iteration after a reset: the stepping thread's pause to take the cut in (last_cut_ms) and the
// time from the stroke to the cut taken (last_cut_made_ms), and the world's steps in between,
// medians over the iterations.
void BM_WorldLoopCut(benchmark::State& state) {
  const bool background = state.range(0) != 0;
  std::vector<world::BodyId> ids;
  world::WorldLoop loop(make_world(3, 1284, ids),
                        {.rate_hz = 0.0, .real_time = false, .background_cuts = background});
  const Eigen::MatrixX3d& X = organs()[0].model->X;
  const Eigen::Vector3d lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  // Across the liver's middle, from above it, 40 mm deep.
  const std::vector<Eigen::Vector3d> path = {{lo.x() + 0.3 * (hi.x() - lo.x()), c.y(), hi.z() + 5},
                                             {lo.x() + 0.7 * (hi.x() - lo.x()), c.y(), hi.z() + 5}};
  const double depth = 5.0 + 0.5 * (hi.z() - lo.z());
  world::WorldSnapshot snap;
  loop.start();
  std::vector<double> pause, made, meanwhile;
  for (auto _ : state) {
    state.PauseTiming();
    loop.reset();
    for (int k = 0; k < 100 && (!loop.latest(snap) || snap.cuts != 0 || snap.steps < 20); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    state.ResumeTiming();
    loop.cut(path, Eigen::Vector3d(0, 0, -1), depth);
    for (int k = 0; k < 2000 && snap.cuts == 0; ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      loop.latest(snap);
    }
    if (snap.cuts == 0) {
      state.SkipWithError(("the stroke cut nothing: " + snap.cut_message).c_str());
      break;
    }
    pause.push_back(snap.last_cut_ms);
    made.push_back(snap.last_cut_made_ms);
    meanwhile.push_back(static_cast<double>(snap.last_cut_steps_meanwhile));
  }
  loop.stop();
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  state.counters["pause_ms"] = median(pause);
  state.counters["made_ms"] = median(made);
  state.counters["tets_cut"] = static_cast<double>(snap.tets_cut);
  state.counters["steps_meanwhile"] = median(meanwhile);
  state.counters["peak_rss_mb"] = bench::peak_rss_mb();
}
BENCHMARK(BM_WorldLoopCut)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("background")
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond);

void BM_LiverAloneStep(benchmark::State& state) {
  const Organ& liver = organs(static_cast<int32_t>(state.range(0)))[0];
  world::BodyDef def = body_of(liver, true);
  sim::Simulation& s = def.simulation;
  for (int k = 0; k < 50; ++k) {
    interact::apply_tools(s, def.tools);
    sim::step(s);
  }
  for (auto _ : state) {
    interact::apply_tools(s, def.tools);
    sim::step(s);
  }
  state.counters["nodes"] = liver.model->node_count();
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["peak_rss_mb"] = bench::peak_rss_mb();
}
BENCHMARK(BM_LiverAloneStep)
    ->Arg(1284)
    ->ArgName("liver_skin")
    ->Iterations(1000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LiverAloneStep)
    ->Arg(5000)
    ->ArgName("liver_skin")
    ->Iterations(200)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LiverAloneStep)
    ->Arg(20000)
    ->Arg(50000)
    ->ArgName("liver_skin")
    ->Iterations(30)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
