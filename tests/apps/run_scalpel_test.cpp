// `lamina run` with a scalpel (issue 47): a scene's blade drawn across the organ with its
// anatomy cuts it as the run goes, into the pieces one cut along the whole path makes, reports
// the vessels it crossed, and the organ comes to rest; a run stopped mid-cut resumes bit for bit
// from its checkpoint; a bad scalpel is one line, exit 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

#include "lamina/model/cut_tetrahedra.h"
#include "support/embedded_phantom.h"
#include "support/run_cli.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

test::RunResult run_lamina(const test::TempDir& dir, const std::string& args) {
  return test::run_cli(test::lamina_cli(), dir.path, dir.path, args);
}

// A scalpel across the embedded phantom at x = x0, front to back, through its whole depth.
struct Across {
  std::vector<Eigen::Vector3d> path;
  double depth_mm = 0.0;
};

Across across(const Model& m) {
  const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
  const double x0 = m.X.col(0).mean() + 0.31;
  return {
      {Eigen::Vector3d(x0, lo.y() - 5, lo.z() - 5), Eigen::Vector3d(x0, hi.y() + 5, lo.z() - 5)},
      hi.z() - lo.z() + 10};
}

json scalpel_scene(const std::string& model, const Across& a) {
  json path = json::array();
  for (const Eigen::Vector3d& p : a.path) path.push_back({p.x(), p.y(), p.z()});
  return {{"model", {{"model", model}}},
          {"tools",
           {{{"scalpel",
              {{"path", path},
               {"direction", {0, 0, 1}},
               {"depth_mm", a.depth_mm},
               {"start_s", 0.05},
               {"end_s", 0.35}}}}}},
          {"output", {{"frame_interval_s", 0.1}}}};
}

TEST(LaminaRunScalpel, CutsAsItGoesIntoThePiecesOfOneCutAndReportsTheVesselsCrossed) {
  test::TempDir dir;
  const Model& m = test::embedded_phantom();
  const Across a = across(m);
  std::ofstream(dir.file("scene.json"))
      << scalpel_scene(test::save_embedded_phantom(dir.file("model.vtu")), a).dump(2);
  const test::RunResult run = run_lamina(dir, "-q run scene.json -o out --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json s = json::parse(run.out);
  EXPECT_TRUE(s["converged"].get<bool>());
  EXPECT_EQ(s["scalpels"], 1);
  EXPECT_GT(s["cuts"].get<int>(), 3) << "cut as the blade went";

  // The same cut at once, along the whole path.
  Model cut;
  std::vector<int32_t> origin;
  model::CutReport whole;
  model::cut_tetrahedra(m, m.X, model::sweep_blade(a.path, Eigen::Vector3d::UnitZ(), a.depth_mm),
                        cut, origin, whole);
  ASSERT_EQ(whole.pieces.size(), 2u);
  EXPECT_NEAR(s["cut_tets"].get<double>(), static_cast<double>(whole.cut_tets),
              0.02 * static_cast<double>(whole.cut_tets));
  ASSERT_EQ(s["pieces"].size(), 2u) << s.dump(2);
  double mass_g = 0.0;
  for (size_t p = 0; p < 2; ++p) {
    EXPECT_NEAR(s["pieces"][p]["volume_ml"].get<double>(), whole.pieces[p].volume_mm3 / 1000.0,
                0.01 * whole.pieces[p].volume_mm3 / 1000.0);
    mass_g += s["pieces"][p]["mass_g"].get<double>();
  }
  const double m0 = 1000.0 * std::accumulate(m.mass_kg.begin(), m.mass_kg.end(), 0.0);
  EXPECT_NEAR(mass_g, m0, 1e-9 * m0);
  EXPECT_EQ(s["nodes"].get<int>(), cut.node_count());

  // The vessels it crossed, each once, with a width; the log said so as it happened.
  int vessels = 0;
  for (const json& c : s["structures_cut"]) {
    EXPECT_GT(c["diameter_mm"].get<double>(), 1.0) << c.dump();
    EXPECT_GE(c["time_s"].get<double>(), 0.05);
    EXPECT_LE(c["time_s"].get<double>(), 0.35 + 1e-9);
    vessels += c["name"] == "vessels";
  }
  EXPECT_GE(vessels, 1) << s["structures_cut"].dump();
  EXPECT_NE(run.err.find("the scalpel cut vessels across"), std::string::npos) << run.err;
  EXPECT_LT(s["final_rest_error_mm"].get<double>(), 1.0);

  // The skin's frames follow the cut: after it, the wound's two sides are skin too.
  std::ifstream pvd(dir.path / "out" / "skin.pvd");
  std::stringstream text;
  text << pvd.rdbuf();
  EXPECT_NE(text.str().find("skin_000004.vtp"), std::string::npos);
  // The wound has its own series from the first cut on: each side's cut surface, which at the
  // end spans the organ's section twice.
  std::ifstream wound(dir.path / "out" / "wound.pvd");
  ASSERT_TRUE(wound.good()) << "no wound series";
  std::stringstream wtext;
  wtext << wound.rdbuf();
  EXPECT_NE(wtext.str().find("frames/wound_"), std::string::npos);
  // Each piece has its own skin series from the cut that made it: together the whole skin.
  for (const char* piece : {"piece1", "piece2"}) {
    std::ifstream p(dir.path / "out" / (std::string(piece) + ".pvd"));
    ASSERT_TRUE(p.good()) << "no " << piece << " series";
    std::stringstream ptext;
    ptext << p.rdbuf();
    EXPECT_NE(ptext.str().find(std::string("frames/") + piece + "_"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(dir.path / "out" / "piece3.pvd"));
}

TEST(LaminaRunScalpel, ABadScalpelIsOneLineExitTwo) {
  test::TempDir dir;
  const Model& m = test::embedded_phantom();
  const std::string model = test::save_embedded_phantom(dir.file("model.vtu"));
  json bad = scalpel_scene(model, across(m));
  bad["tools"][0]["scalpel"]["depth_mm"] = 0;
  std::ofstream(dir.file("bad.json")) << bad.dump(2);
  const test::RunResult r = run_lamina(dir, "run bad.json -o out");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "lamina: error: bad.json: tools[0].scalpel.depth_mm: must be > 0 mm, got 0\n");
  EXPECT_FALSE(fs::exists(dir.path / "out"));

  json along = scalpel_scene(model, across(m));
  along["tools"][0]["scalpel"]["direction"] = {0, 1, 0};  // along the path: cuts nothing
  std::ofstream(dir.file("along.json")) << along.dump(2);
  const test::RunResult a = run_lamina(dir, "run along.json -o out");
  EXPECT_EQ(a.exit_code, 2);
  EXPECT_NE(a.err.find("along.json: tools[0].scalpel.direction: runs along the path"),
            std::string::npos)
      << a.err;
}

// Every file a run wrote but its timing (metrics.csv's step_us, summary.json, the checkpoint).
std::map<std::string, std::string> outputs_of(const fs::path& out) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    const std::string name = fs::relative(e.path(), out).string();
    if (!e.is_regular_file() || name == "summary.json" || name == "checkpoint.lmck") continue;
    std::string text = test::read_text(e.path());
    if (name == "metrics.csv") {  // drop column 6, each step's wall time
      std::istringstream rows(text);
      std::string row, kept;
      while (std::getline(rows, row)) {
        size_t a = 0;
        for (int c = 0; c < 5; ++c) a = row.find(',', a) + 1;
        kept += row.substr(0, a) + row.substr(row.find(',', a) + 1) + "\n";
      }
      text = kept;
    }
    files[name] = std::move(text);
  }
  return files;
}

TEST(LaminaRunScalpel, AStoppedRunWithAScalpelResumesBitForBit) {
  // Stopped twice while the blade is halfway through (the model cut, the vessels split, a
  // tool pushing next to the wound), the run resumes from its checkpoints into the same cut
  // organ and writes what the run that never stopped wrote, file for file.
  test::TempDir dir;
  const Model& m = test::embedded_phantom();
  const Across a = across(m);
  json scene = scalpel_scene(test::save_embedded_phantom(dir.file("model.vtu")), a);
  const Eigen::Vector3d front(a.path[0].x() - 12.0, m.X.col(1).minCoeff(), m.X.col(2).mean());
  scene["tools"].push_back({{"point", {front.x(), front.y(), front.z()}},
                            {"force_n", {0, 0.2, 0.1}},
                            {"start_s", 0.1},
                            {"end_s", 0.5}});
  std::ofstream(dir.file("scene.json")) << scene.dump(2);
  const test::RunResult whole = run_lamina(dir, "-q run scene.json -o whole");
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const test::RunResult part =
      run_lamina(dir, "-q run scene.json -o part --stop-after 150 --checkpoint-every 40");
  ASSERT_EQ(part.exit_code, 0) << part.err;
  const json stopped = json::parse(test::read_text(dir.path / "part" / "summary.json"));
  ASSERT_GT(stopped["cuts"].get<int>(), 0);  // the checkpoint holds a cut model
  const test::RunResult more =
      run_lamina(dir, "-q run -o part --resume part/checkpoint.lmck --stop-after 100");
  ASSERT_EQ(more.exit_code, 0) << more.err;
  const test::RunResult rest = run_lamina(dir, "-q run -o part --resume part/checkpoint.lmck");
  ASSERT_EQ(rest.exit_code, 0) << rest.err;

  const json w = json::parse(test::read_text(dir.path / "whole" / "summary.json"));
  const json p = json::parse(test::read_text(dir.path / "part" / "summary.json"));
  ASSERT_TRUE(w["converged"].get<bool>());
  EXPECT_GT(w["cuts"].get<int>(), stopped["cuts"].get<int>());  // it cut after the resume too
  for (const char* key :
       {"converged", "steps", "sim_seconds", "max_displacement_mm", "final_rest_error_mm", "frames",
        "max_reaction_n", "nodes", "cuts", "cut_tets", "pieces", "structures_cut"})
    EXPECT_EQ(w[key], p[key]) << key;
  const auto expected = outputs_of(dir.path / "whole"), got = outputs_of(dir.path / "part");
  EXPECT_TRUE(expected.contains("wound.pvd"));
  ASSERT_EQ(expected.size(), got.size());
  for (const auto& [name, text] : expected) {
    ASSERT_TRUE(got.contains(name)) << name;
    EXPECT_TRUE(got.at(name) == text) << name << " differs";
  }

  // A checkpoint of a run with scalpels resumes only that run.
  json other = scene;
  other["tools"].erase(0);
  std::ofstream(dir.file("other.json")) << other.dump(2);
  const test::RunResult wrong =
      run_lamina(dir, "-q run other.json -o part --resume part/checkpoint.lmck");
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_EQ(wrong.err.find('\n'), wrong.err.size() - 1) << wrong.err;
}

}  // namespace
}  // namespace lamina
