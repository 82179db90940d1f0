// What holds the organ besides its fixed nodes: per node, a zero-length spring to its rest
// position. Material::anchor_stiffness_n_per_m ties every node alike (the paper-era "support
// from the surrounding tissue"); support_nodes() ties a surface per unit area, as the tissue and
// organs around a liver hold its bare area (model::surface_support).
#include "force_terms.h"
#include "solver.h"

namespace lamina::sim::detail {

void setup_support(Solver& s) {
  const auto n = static_cast<size_t>(s.model->node_count());
  SupportTerm& t = s.support;
  if (t.support_n_per_m.size() != n) t.support_n_per_m.assign(n, 0.0);
  if (t.contact_n_per_m.size() != n) {
    t.contact_n_per_m.assign(n, 0.0);
    t.contact_nodes.clear();
  }
  t.stiffness_n_per_m.resize(n);
  for (size_t i = 0; i < n; ++i)
    t.stiffness_n_per_m[i] =
        s.material.anchor_stiffness_n_per_m + t.support_n_per_m[i] + t.contact_n_per_m[i];
}

double NodeSupport::energy_mj(const Solver& s, const Eigen::MatrixX3d& x) {
  double e = 0.0;
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    e += 0.5 * s.support.stiffness_n_per_m[static_cast<size_t>(i)] *
         (x.row(i) - s.model->X.row(i)).squaredNorm();  // N/m mm^2 = 1e-6 J
  return e;
}

void NodeSupport::forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    f.row(i) -=
        s.support.stiffness_n_per_m[static_cast<size_t>(i)] * (x.row(i) - s.model->X.row(i));
}

void NodeSupport::add_stiffness_rows(const Solver& s, std::vector<double>& row) {
  for (size_t i = 0; i < row.size(); ++i) row[i] += s.support.stiffness_n_per_m[i];
}

void NodeSupport::add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row,
                                     BlockRows& K) {
  for (int32_t i = 0; i < s.model->node_count(); ++i)
    if (row[i] >= 0) {
      double* block = K.at(row[i], row[i]);
      for (int c = 0; c < 3; ++c) block[4 * c] += s.support.stiffness_n_per_m[i];
    }
}

}  // namespace lamina::sim::detail
