// docs/viewer.md's "Embedding the viewer" examples, compiled and run on the mock backend: the
// three calls, then an app that owns the loop, steps its own simulation between frames and
// builds a panel in the callback. Each example is the block between the markers; what differs
// from the docs (the backend, a frame limit: a mock window never closes) is said beside it.
#include <gtest/gtest.h>
#include <imgui.h>

#include "lamina/render/viewer.h"
#include "lamina/sim/simulation.h"
#include "support/sphere_model.h"

namespace lamina {
namespace {

// The most anterior skin node (pushed posteriorly, +y) and the posterior cap (held).
struct Push {
  Eigen::Index node = 0;
  std::vector<int32_t> back;
  explicit Push(const Model& model) {
    model.X.topRows(model.layers[0].node_count).col(1).minCoeff(&node);
    const double y_max = model.X.col(1).maxCoeff();
    for (int32_t i = 0; i < model.node_count(); ++i)
      if (model.X(i, 1) > y_max - 8.0) back.push_back(i);
  }
};

TEST(ViewerEmbedding, ThreeCalls) {
  const Model& model = test::sphere_model();
  int frames = 0;
  // ---- docs/viewer.md, first example ----
  render::init(render::Backend::kMock);    // the docs: render::init(), a window
  render::register_model("liver", model);  // copied: `model` stays the app's
  render::set_callback([&] {               // (the mock's window closes after 10 frames)
    if (++frames == 10) render::request_close();
  });
  render::show();
  // ---- end ----
  EXPECT_EQ(frames, 10) << "show() did not return when the window closed";
  EXPECT_EQ(render::frame_count(), 10);
  EXPECT_EQ(render::structure_stats("liver").uploads, 1);
  render::shutdown();
}

TEST(ViewerEmbedding, TheAppStepsItsOwnSimulationBetweenFrames) {
  const Model& model = test::sphere_model();
  const Push setup(model);
  const Eigen::Index node = setup.node;
  int frames = 0;
  // ---- docs/viewer.md, second example ----
  render::init(render::Backend::kMock);  // the docs: render::init()
  render::register_model("liver", model);
  sim::Simulation s = sim::make_simulation(model);
  sim::fix_nodes(s, setup.back);  // (the docs leave the boundary out)
  float force_n = 0.4f;
  render::set_callback([&] { ImGui::SliderFloat("push, N", &force_n, 0.0f, 2.0f); });
  while (render::frame_tick() && frames++ < 100) {  // the docs: while (render::frame_tick())
    s.f_ext.row(node) = Eigen::RowVector3d(0.0, 1000.0 * force_n, 0.0);  // mN
    sim::step(s);
    render::update_positions("liver", s.x);  // uploaded at the next frame
  }
  // ---- end ----
  EXPECT_EQ(render::positions("liver"), s.x) << "the engine does not show the app's last step";
  EXPECT_GT(s.x(node, 1) - model.X(node, 1), 0.5) << "the push did not dent the organ";
  // Every frame drew the state stepped before it: one upload a frame (the first sends the model).
  EXPECT_EQ(render::frame_count(), 101);
  EXPECT_EQ(render::structure_stats("liver").uploads, 101);
  EXPECT_EQ(render::structure_stats("liver").updates, 100);
  render::shutdown();
}

}  // namespace
}  // namespace lamina
