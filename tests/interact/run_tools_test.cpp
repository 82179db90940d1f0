#include "lamina/interact/run_tools.h"

#include <gtest/gtest.h>

#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "support/sphere_model.h"

namespace {
using namespace lamina;

// The default scene on the test sphere: a physical material held at its back, one poke.
struct Poked {
  io::Scene scene;
  io::ReadyScene ready;
  sim::Simulation sim;
  interact::ToolDriver driver;
  explicit Poked(double end_s) {
    scene.tools.push_back({.vertex = 10, .force_mn = {0.0, 0.0, -200.0}, .end_s = end_s});
    scene.default_tool = false;
    ready = io::make_ready_scene(scene, io::SceneModel{test::sphere_model(), "sphere"});
    sim = io::make_scene_simulation(ready);
    driver = io::make_tool_driver(ready.scene);
  }
};

// The run is over when the tool has let go and the model has rested for sim::quiet_steps() in a
// row: not before the release, and not at the first quiet step.
TEST(RunTools, StopsAtRestAfterTheLastReleaseAndNotBefore) {
  Poked p(0.2);
  int64_t quiet_before_release = 0;
  int64_t steps_seen = 0;
  double peak_mm = 0.0;
  const interact::ToolRun run = interact::run_tools(
      p.sim, p.driver, 30.0, /*stop_at_rest=*/true,
      [&](const sim::Simulation& s, const interact::ToolDriver&, const sim::StepStats& st) {
        ++steps_seen;
        peak_mm = std::max(peak_mm, st.max_displacement_mm);
        if (s.time_s <= 0.2 && sim::at_rest(st)) ++quiet_before_release;
      });
  ASSERT_TRUE(run.converged);
  EXPECT_EQ(run.steps, steps_seen) << "the observer saw every step";
  EXPECT_GT(peak_mm, 0.1) << "the tool pushed";
  EXPECT_GT(p.sim.time_s, 0.2) << "stopped before the tool let go";
  EXPECT_TRUE(sim::at_rest(run.last));
  EXPECT_LT(run.last.max_displacement_mm, 0.1 * peak_mm) << "back near rest";
  // RestWatch counted from the release: a streak of quiet steps, the last of them this one.
  const interact::RestWatch w = interact::rest_watch(p.sim, p.driver);
  EXPECT_DOUBLE_EQ(w.settle_from_s, 0.2);
  EXPECT_EQ(w.quiet.needed, sim::quiet_steps(p.sim));
}

// Without stop_at_rest the loop runs to the time asked, whatever the model does.
TEST(RunTools, WithoutStopAtRestRunsToTheEndTime) {
  Poked p(0.05);
  const interact::ToolRun run = interact::run_tools(p.sim, p.driver, 0.3, false);
  EXPECT_NEAR(p.sim.time_s, 0.3, 1e-9);
  EXPECT_EQ(run.steps, p.sim.steps);
  EXPECT_FALSE(run.converged);
}

// A quiet step before the settle time does not count, and one motion step restarts the count.
TEST(RestWatch, CountsQuietStepsInARowFromTheSettleTime) {
  interact::RestWatch w{.settle_from_s = 1.0, .quiet = {.needed = 3}};
  sim::StepStats quiet;
  quiet.converged = true;
  sim::StepStats moving;
  EXPECT_FALSE(w.update(0.5, quiet));
  EXPECT_FALSE(w.update(0.9, quiet));
  EXPECT_EQ(w.quiet.streak, 0) << "before the settle time";
  EXPECT_FALSE(w.update(1.0, quiet));
  EXPECT_FALSE(w.update(1.1, quiet));
  EXPECT_FALSE(w.update(1.2, moving));
  EXPECT_EQ(w.quiet.streak, 0);
  EXPECT_FALSE(w.update(1.3, quiet));
  EXPECT_FALSE(w.update(1.4, quiet));
  EXPECT_TRUE(w.update(1.5, quiet));
}

}  // namespace
