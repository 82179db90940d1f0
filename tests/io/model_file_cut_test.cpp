// A cut model in the model file (format version 5, docs/model_format.md): the phantom with its
// anatomy, divided by a plane into two pieces (tetrahedra copied with their shares and
// materials, the display skin, vessels and tumour split, the wound), comes back bit for bit and
// simulates exactly as the model it was saved from; the checksum covers the shares; a share or
// material out of range is refused on load with one line naming the cell.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/io/model_file.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"
#include "support/embedded_phantom.h"
#include "support/model_file_text.h"
#include "support/temp_dir.h"
#include "support/tet_phantom.h"

namespace lamina::io {
namespace {

using namespace lamina::test;

// The phantom cut through by a plane across x, a third of the way along.
const Model& cut_phantom() {
  static const Model cut = [] {
    const Model& m = embedded_phantom();
    const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
    const double x0 = lo.x() + (hi.x() - lo.x()) / 3.0;
    const model::Blade blade = model::sweep_blade({Eigen::Vector3d(x0, lo.y() - 10, lo.z() - 10),
                                                   Eigen::Vector3d(x0, hi.y() + 10, lo.z() - 10)},
                                                  Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 20);
    Model out;
    std::vector<int32_t> origin;
    model::CutReport report;
    model::cut_tetrahedra(m, m.X, blade, out, origin, report);
    EXPECT_EQ(report.pieces.size(), 2u);
    return out;
  }();
  return cut;
}

// Its first tetrahedron with a share below 1 (a copy the cut made).
int64_t first_copy(const Model& m) {
  for (int64_t t = 0; t < m.tets.size(); ++t)
    if (m.tets.share_of(t) < 1.0) return t;
  return -1;
}

int64_t cells_before_tets(const Model& m) {
  int64_t cells = static_cast<int64_t>(m.springs.size());
  for (const ModelLayer& l : m.layers) cells += l.F.rows();
  return cells;
}

TEST(ModelFileCut, ACutModelRoundTripsBitExactlyAndSimulatesTheSame) {
  const TempDir dir;
  const Model& m = cut_phantom();
  ASSERT_GE(first_copy(m), 0);
  const std::string path = dir.file("cut.vtu");
  save_model(m, path);
  // With embedded surfaces (the wound), version 6 (their roles); the shares as in version 5.
  EXPECT_NE(file_text(path).find("Name=\"lamina_format_version\" NumberOfTuples=\"1\" "
                                 "format=\"ascii\">\n        6\n"),
            std::string::npos);
  const Model loaded = load_model(path);
  expect_same_model(m, loaded);
  EXPECT_EQ(model_fingerprint(loaded), model_fingerprint(m));

  // What the shares are for: the same motion, bit for bit, under the same load.
  const auto pushed = [](const Model& model) {
    sim::Simulation s =
        sim::make_simulation(model, kTetLiver, {.integrator = sim::Integrator::kImplicitEuler});
    s.f_ext.row(0) = Eigen::RowVector3d(0.0, 200.0, 0.0);
    for (int k = 0; k < 20; ++k) sim::step(s);
    return Eigen::MatrixX3d(s.x);
  };
  const Eigen::MatrixX3d a = pushed(m), b = pushed(loaded);
  EXPECT_GT((a - m.X).norm(), 1e-3);  // it moved
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
}

TEST(ModelFileCut, TheChecksumCoversTheShares) {
  const Model& m = cut_phantom();
  const int64_t t = first_copy(m);
  Model edited = m;
  edited.tets.share[static_cast<size_t>(t)] =
      std::bit_cast<double>(std::bit_cast<uint64_t>(m.tets.share[static_cast<size_t>(t)]) ^ 1);
  EXPECT_NE(model_fingerprint(edited), model_fingerprint(m));
  edited = m;
  edited.tets.material[static_cast<size_t>(t)] ^= 1;
  EXPECT_NE(model_fingerprint(edited), model_fingerprint(m));
  // An uncut model keeps the checksum it always had (checkpoints name their model by it).
  Model uncut = tet_phantom();
  const uint32_t before = model_fingerprint(uncut);
  uncut.tets.share.assign(static_cast<size_t>(uncut.tets.size()), 1.0);
  EXPECT_NE(model_fingerprint(uncut), before);  // shares given are shares counted
}

TEST(ModelFileCut, SharesAndMaterialsOutOfRangeAreRefusedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("cut.vtu");
  const Model& m = cut_phantom();
  const int64_t t = first_copy(m), tet_cell = cells_before_tets(m) + t;
  const int64_t spring_cell = cells_before_tets(m) - 1;  // the last spring
  const ModelCorruptions cases = {
      {[t](Model& c) { c.tets.share[static_cast<size_t>(t)] = 0.0; },
       "cell " + std::to_string(tet_cell) + ": share is 0, must lie in (0, 1]"},
      {[t](Model& c) { c.tets.share[static_cast<size_t>(t)] = 1.5; }, "share is 1.5"},
      {[t](Model& c) { c.tets.share[static_cast<size_t>(t)] = std::nan(""); }, "share is nan"},
      {[](Model& c) { c.springs.share.back() = -0.25; },
       "cell " + std::to_string(spring_cell) + ": share is -0.25"},
      {[t](Model& c) { c.tets.material[static_cast<size_t>(t)] = 0; },
       "cell " + std::to_string(tet_cell) + ": material is 0, must name corners 1 to 15"},
      {[t](Model& c) { c.tets.material[static_cast<size_t>(t)] = 16; }, "material is 16"},
  };
  expect_each_refused_on_load(
      path, [] { return cut_phantom(); }, cases);
}

TEST(ModelFileCut, ATriangleWithAShareIsRefusedOnLoad) {
  // Only the text can give a triangle a share: the first cell is layer 0's first triangle.
  const TempDir dir;
  const std::string path = dir.file("cut.vtu");
  save_model(cut_phantom(), path);
  std::string text = file_text(path);
  const size_t at = text.find("Name=\"share\"");
  ASSERT_NE(at, std::string::npos);
  const size_t first = text.find_first_not_of(" \n", text.find('>', at) + 1);
  ASSERT_EQ(text.substr(first, 2), "1 ");
  text.replace(first, 1, "0.5");
  write_text(path, text);
  expect_load_error(path, "cell 0: a triangle's share must be 1 and its material 15, found 0.5");
}

}  // namespace
}  // namespace lamina::io
