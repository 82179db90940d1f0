// Surfaces carried by the tetrahedra (model/embed_surface.h): at rest the map gives back the
// surface itself, it reproduces every affine motion exactly (barycentric weights do), a vertex
// on a node follows that node exactly, a vertex outside every tetrahedron follows the nearest one
// and is counted, and bad input is refused by the surface's name.
#include "lamina/model/embed_surface.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <iostream>

#include "lamina/core/error.h"
#include "support/random_rows.h"
#include "support/sphere_model.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

// The model's own skin as a separate surface.
void skin_of(const Model& m, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  const ModelLayer& skin = m.layers[0];
  V = m.X.topRows(skin.node_count);
  F = skin.F;  // the skin's nodes come first: global indices are the surface's
}

TEST(EmbedSurface, AtRestItIsTheSurfaceAndAnAffineMotionIsReproducedExactly) {
  const Model& m = test::tet_phantom();
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  skin_of(m, V, F);
  // Inside the organ too: the skin shrunk 20% towards its centroid (vessels, a tumour).
  const Eigen::RowVector3d centre = V.colwise().mean();
  const Eigen::MatrixX3d inner = (V.rowwise() - centre) * 0.8 + centre.replicate(V.rows(), 1);
  for (const Eigen::MatrixX3d* surface : {static_cast<const Eigen::MatrixX3d*>(&V), &inner}) {
    const EmbeddedSurface e =
        model::embed_surface(m, *surface, F, "skin copy", SurfaceRole::kDisplaySkin);
    EXPECT_EQ(e.outside, 0);
    EXPECT_LT((e.weights.rowwise().sum().array() - 1.0).abs().maxCoeff(), 1e-12);
    Eigen::MatrixX3d out;
    model::embedded_positions(e, m.X, out);
    EXPECT_LT((out - *surface).cwiseAbs().maxCoeff(), 1e-9);
    // x = A X + b: barycentric weights reproduce it on every vertex.
    Eigen::Matrix3d A;
    A << 1.1, 0.2, 0.0, -0.1, 0.9, 0.3, 0.05, 0.0, 1.2;
    const Eigen::RowVector3d b(3.0, -2.0, 7.0);
    const Eigen::MatrixX3d x = (m.X * A.transpose()).rowwise() + b;
    model::embedded_positions(e, x, out);
    const Eigen::MatrixX3d expected = (*surface * A.transpose()).rowwise() + b;
    EXPECT_LT((out - expected).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(EmbedSurface, AVertexOnANodeFollowsItUnderAnyDeformation) {
  // The skin's own vertices are tetrahedron corners: under a random (non-affine) motion each
  // equals its node's position.
  const Model& m = test::tet_phantom();
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  skin_of(m, V, F);
  const EmbeddedSurface e = model::embed_surface(m, V, F, "skin copy", SurfaceRole::kDisplaySkin);
  const Eigen::MatrixX3d x = test::jiggle(m.X, 2.0, 4);
  Eigen::MatrixX3d out;
  model::embedded_positions(e, x, out);
  EXPECT_LT((out - x.topRows(V.rows())).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(EmbedSurface, VerticesOutsideFollowTheTetrahedronTheyAreLeastOutsideOfAndAreCounted) {
  const Model& m = test::tet_phantom();
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  skin_of(m, V, F);
  // Grown 3% about the centroid: most of the skin's vertices leave the organ.
  const Eigen::RowVector3d centre = V.colwise().mean();
  const Eigen::MatrixX3d outer = (V.rowwise() - centre) * 1.03 + centre.replicate(V.rows(), 1);
  const EmbeddedSurface e =
      model::embed_surface(m, outer, F, "grown skin", SurfaceRole::kDisplaySkin);
  EXPECT_GT(e.outside, V.rows() / 2);
  EXPECT_LT(e.outside, V.rows() + 1);
  Eigen::MatrixX3d out;
  model::embedded_positions(e, m.X, out);
  EXPECT_LT((out - outer).cwiseAbs().maxCoeff(), 1e-9) << "extrapolated, still exact at rest";
  // Its tetrahedron is the one it is least outside of: the weights extrapolate mildly (the
  // nearest centroid alone gave this grown skin sums of |weights| up to 3.8; now 1.74).
  const double gain = e.weights.cwiseAbs().rowwise().sum().maxCoeff();
  std::cout << "largest sum of |weights| of a vertex: " << gain << "\n";
  EXPECT_LT(gain, 2.0);
}

TEST(EmbedSurface, BadInputIsRefusedByName) {
  const Model& m = test::tet_phantom();
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  skin_of(m, V, F);
  const auto refused = [](auto&& call, const std::string& words) {
    try {
      call();
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
      EXPECT_NE(std::string(e.what()).find("vessel"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  Eigen::MatrixX3i bad_f = F;
  bad_f(0, 0) = static_cast<int>(V.rows());
  refused([&] { model::embed_surface(m, V, bad_f, "vessel", SurfaceRole::kVessel); },
          "vertex the surface does not have");
  Eigen::MatrixX3d bad_v = V;
  bad_v(3, 1) = std::nan("");
  refused([&] { model::embed_surface(m, bad_v, F, "vessel", SurfaceRole::kVessel); }, "not finite");
  refused(
      [&] { model::embed_surface(m, Eigen::MatrixX3d(0, 3), F, "vessel", SurfaceRole::kVessel); },
      "empty");
  const Model& links = test::sphere_model(nullptr, model::Structure::kLinks);
  refused([&] { model::embed_surface(links, V, F, "vessel", SurfaceRole::kVessel); },
          "no tetrahedra");
}

}  // namespace
