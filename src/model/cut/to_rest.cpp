// Points given against a deformed state, carried back to the rest shape (and back again) by the
// tetrahedra that hold them: a scalpel drawn on a moving organ cuts the material it passed through.
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <limits>

#include "cut_internal.h"
#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"

namespace lamina::model {

namespace {

// Points given at node positions x carried to node positions y by the tetrahedra T.
Eigen::MatrixX3d carry(const Model& model, const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& y,
                       const Eigen::MatrixX3d& points) {
  if (!model.has_tets())
    throw invalid_input("cut",
                        "the model has no tetrahedra: only a model with tetrahedra can be cut");
  if (x.rows() != model.X.rows() || !x.allFinite())
    throw invalid_input("cut", "the positions do not match the model or are not finite");
  if (!points.allFinite()) throw invalid_input("blade", "has a point that is not finite");
  Eigen::MatrixX3d rest(points.rows(), 3);
  if (points.rows() == 0) return rest;
  const Eigen::MatrixX4i& T = model.tets.T;

  // The tetrahedra near the points: their boxes within a margin of the points' box (the mean
  // edge of those, so that a point just outside the organ finds the face it is outside of).
  Eigen::AlignedBox3d box;
  for (Eigen::Index p = 0; p < points.rows(); ++p) box.extend(points.row(p).transpose());
  double edge = 0.0;
  for (int k = 1; k < 4; ++k) edge += (x.row(T(0, k)) - x.row(T(0, 0))).norm();
  double margin = edge / 3.0;
  std::vector<int32_t> near;
  std::vector<Eigen::Matrix3d> inverse;
  for (int attempt = 0; near.empty() && attempt < 8; ++attempt, margin *= 4.0) {
    const Eigen::AlignedBox3d reach(box.min().array() - margin, box.max().array() + margin);
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      if (!reach.intersects(detail::tet_box(x, T, t))) continue;
      Eigen::Matrix3d D;
      for (int k = 1; k < 4; ++k) D.col(k - 1) = (x.row(T(t, k)) - x.row(T(t, 0))).transpose();
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(D);
      if (!lu.isInvertible()) continue;  // a collapsed tetrahedron locates nothing
      near.push_back(static_cast<int32_t>(t));
      inverse.push_back(lu.inverse());
    }
  }
  if (near.empty()) throw invalid_input("blade", "is nowhere near the organ");

  // Each point at its weights in the tetrahedron holding it, or in the one it is least outside
  // of (the largest smallest weight: the mildest extrapolation).
  for (Eigen::Index p = 0; p < points.rows(); ++p) {
    const Eigen::Vector3d q = points.row(p).transpose();
    double best = -std::numeric_limits<double>::infinity();
    Eigen::Vector4d w_best = Eigen::Vector4d::Zero();
    int32_t t_best = -1;
    for (size_t c = 0; c < near.size(); ++c) {
      const int32_t t = near[c];
      const Eigen::Vector3d l = inverse[c] * (q - x.row(T(t, 0)).transpose());
      const Eigen::Vector4d w(1.0 - l.sum(), l[0], l[1], l[2]);
      if (w.minCoeff() > best) best = w.minCoeff(), w_best = w, t_best = t;
      if (best >= 0.0) break;  // inside
    }
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) r += w_best[k] * y.row(T(t_best, k)).transpose();
    rest.row(p) = r.transpose();
  }
  return rest;
}

}  // namespace

Eigen::MatrixX3d to_rest(const Model& model, const Eigen::MatrixX3d& x,
                         const Eigen::MatrixX3d& points) {
  return carry(model, x, model.X, points);
}

Eigen::MatrixX3d from_rest(const Model& model, const Eigen::MatrixX3d& x,
                           const Eigen::MatrixX3d& points) {
  if (x.rows() != model.X.rows() || !x.allFinite())
    throw invalid_input("cut", "the positions do not match the model or are not finite");
  return carry(model, model.X, x, points);
}

}  // namespace lamina::model
