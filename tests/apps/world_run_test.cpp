// `lamina build --organ` and `lamina run` on a world scene (issue 62): the TotalSegmentator
// example made into a model per organ and a world scene that runs; the shipped cholecystectomy
// frees the gallbladder with no inverted tetrahedron and the liver back at rest; a body's own
// scalpel cuts it as it moves with its attachment holding; a scene naming
// a body or a label that does not exist is one line, exit 2, nothing written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "support/refusal.h"
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

std::string data(const std::string& name) {
  return test::quoted(test::source_path("tests/data/" + name).string());
}

TEST(LaminaBuildOrgans, AModelPerOrganAndAWorldSceneOfThemThatRuns) {
  test::TempDir dir;
  const test::RunResult b = run_lamina(
      dir, "-q build " + data("liver_totalseg_example_3mm_labels.nii.gz") +
               " --organ 1=liver,4=gallbladder --organ-mask " +
               data("kidney_right_totalseg_example_3mm.nii.gz") +
               "=kidney_right --embed 2=portal_vein --skin-vertices 1000 -o organs --json");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const json built = json::parse(b.out);
  ASSERT_EQ(built["organs"].size(), 3u);
  std::set<std::string> names;
  for (const json& o : built["organs"]) {
    names.insert(o["name"].get<std::string>());
    EXPECT_TRUE(fs::exists(dir.path / "organs" / (o["name"].get<std::string>() + ".vtu")));
    EXPECT_GT(o["tetrahedra"].get<int64_t>(), 100);
  }
  EXPECT_EQ(names, (std::set<std::string>{"liver", "gallbladder", "kidney_right"}));
  EXPECT_EQ(built["organs"][0]["structures"], json::array({"portal_vein"}));
  // The liver touches both: attached to both in the scene.
  bool liver_gallbladder = false;
  for (const json& t : built["touching"])
    liver_gallbladder |= t["bodies"] == json::array({"liver", "gallbladder"});
  EXPECT_TRUE(liver_gallbladder) << built["touching"].dump();

  const test::RunResult r = run_lamina(dir, "-q run organs/scene.json -o run --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json s = json::parse(r.out);
  EXPECT_TRUE(s["world"].get<bool>());
  EXPECT_TRUE(s["converged"].get<bool>());
  ASSERT_EQ(s["bodies"].size(), 3u);
  for (const json& body : s["bodies"]) {
    EXPECT_GT(body["nodes"].get<int64_t>(), 100);
    // Nothing moves them: each stays where the CT has it, the contact holding its rest overlap.
    EXPECT_LT(body["max_displacement_mm"].get<double>(), 0.05) << body.dump();
    EXPECT_LE(body["max_penetration_mm"].get<double>(), 0.05) << body.dump();
  }
  EXPECT_GT(s["attachments"]["total"].get<int64_t>(), 50);
  EXPECT_EQ(s["attachments"]["divided"].get<int64_t>(), 0);
  for (const char* f : {"metrics.csv", "summary.json", "liver_skin.pvd", "gallbladder_skin.pvd",
                        "kidney_right_skin.pvd", "liver_portal_vein.pvd", "ties.pvd"})
    EXPECT_TRUE(fs::exists(dir.path / "run" / f)) << f;
}

TEST(LaminaRunWorld, TheCholecystectomyFreesTheGallbladderAndTheLiverComesBackToRest) {
  test::TempDir dir;
  const std::string scene = test::source_path("examples/cholecystectomy.json").string();
  const test::RunResult r = run_lamina(dir, "-q run " + test::quoted(scene) + " -o out --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json s = json::parse(r.out);
  EXPECT_TRUE(s["converged"].get<bool>());
  EXPECT_FALSE(s["unstable"].get<bool>());
  // Free: every tie of the bed divided by the blade or torn.
  const json& at = s["attachments"];
  EXPECT_GT(at["total"].get<int64_t>(), 100);
  EXPECT_EQ(at["divided"].get<int64_t>() + at["torn"].get<int64_t>(), at["total"].get<int64_t>());
  EXPECT_TRUE(at["each"][0]["free"].get<bool>());
  for (const json& body : s["bodies"]) {
    SCOPED_TRACE(body["name"].get<std::string>());
    EXPECT_EQ(body["max_inverted_tets"].get<int64_t>(), 0);  // at any step
    EXPECT_LE(body["max_penetration_mm"].get<double>(), 0.5);
  }
  const json& liver = s["bodies"][0];
  ASSERT_EQ(liver["name"], "liver");
  // Pulled by its bed while the gallbladder was retracted, then let go by the dissection.
  EXPECT_GT(liver["max_displacement_mm"].get<double>(), 5.0);
  EXPECT_LT(liver["final_rest_error_mm"].get<double>(), 0.5);
  const json& gallbladder = s["bodies"][1];
  EXPECT_GT(gallbladder["max_displacement_mm"].get<double>(), 20.0);  // held by the grasper
}

// A body's own scalpel in a world scene: it cuts the liver's left lobe as it moves (several
// cuts, each through the world's renumbering), while the gallbladder stays tied to its bed on
// the liver's nodes; the wound gets a series; every body rests with no tetrahedron inverted.
TEST(LaminaRunWorld, ABodysScalpelCutsItAsItMovesAndTheWorldRestsAfter) {
  test::TempDir dir;
  const std::string labels =
      test::source_path("tests/data/liver_totalseg_example_3mm_labels.nii.gz").string();
  std::ofstream(dir.path / "cut.json") << R"({
    "bodies": [
      {"name": "liver", "model": {"input": ")" +
                                              labels + R"(",
                                  "build": {"label": 1, "skin_vertices": 600, "display_triangles": 0}},
       "tools": [{"scalpel": {"path": [[10, -275, 440], [10, -205, 440]], "direction": [0, 0, -1],
                              "depth_mm": 40, "start_s": 0.0, "end_s": 0.3}}]},
      {"name": "gallbladder", "model": {"input": ")" +
                                              labels + R"(",
                                        "build": {"label": 4, "skin_vertices": 300, "display_triangles": 0}}}],
    "attachments": [{"name": "bed", "bodies": ["liver", "gallbladder"], "reach_mm": 3.0}],
    "contact": {"rest_overlap_tolerance_mm": 6.0},
    "solver": {"integrator": "implicit_euler", "dt_s": 0.001, "max_steps": 4000}})";
  const test::RunResult r = run_lamina(dir, "-q run cut.json -o out --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json s = json::parse(r.out);
  EXPECT_TRUE(s["converged"].get<bool>());
  const json& liver = s["bodies"][0];
  ASSERT_EQ(liver["name"], "liver");
  EXPECT_GE(liver["cuts"].get<int32_t>(), 2) << "the blade cuts as it goes";
  EXPECT_GT(liver["cut_tetrahedra"].get<int64_t>(), 10);
  EXPECT_GT(liver["new_nodes"].get<int64_t>(), 0);
  EXPECT_FALSE(s["bodies"][1].contains("cuts"));  // no scalpel of its own
  for (const json& body : s["bodies"]) {
    SCOPED_TRACE(body["name"].get<std::string>());
    EXPECT_EQ(body["max_inverted_tets"].get<int64_t>(), 0);
    EXPECT_LT(body["final_rest_error_mm"].get<double>(), 0.5);
  }
  // The bed's ties held through the liver's renumberings: none torn, none lost.
  EXPECT_GT(s["attachments"]["total"].get<int64_t>(), 20);
  EXPECT_EQ(s["attachments"]["torn"].get<int64_t>(), 0);
  for (const char* f : {"liver_skin.pvd", "liver_wound.pvd", "gallbladder_skin.pvd", "ties.pvd"})
    EXPECT_TRUE(fs::exists(dir.path / "out" / f)) << f;
}

TEST(LaminaRunWorld, ABodyOrLabelThatDoesNotExistIsOneLineAndNothingIsWritten) {
  test::TempDir dir;
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir.path / name) << text;
  };
  const std::string labels =
      test::source_path("tests/data/liver_totalseg_example_3mm_labels.nii.gz");
  write("attach.json", R"({"bodies": [{"name": "liver", "model": {"input": ")" + labels +
                           R"(", "build": {"label": 1}}}],
                           "attachments": [{"bodies": ["liver", "stomach"]}]})");
  test::RunResult r = run_lamina(dir, "run attach.json -o out");
  EXPECT_EQ(test::refusal_problems(r, {"attach.json: attachments[0].bodies[1]", "stomach"}, {"out"},
                                   dir.path),
            std::vector<std::string>{});
  write("label.json", R"({"bodies": [{"name": "spleen", "model": {"input": ")" + labels +
                          R"(", "build": {"label": 9}}}]})");
  r = run_lamina(dir, "run label.json -o out");
  EXPECT_EQ(
      test::refusal_problems(r, {"label.json: bodies[0] ('spleen')", "label 9"}, {"out"}, dir.path),
      std::vector<std::string>{});
  write("twice.json", R"({"bodies": [{"name": "a", "model": {"input": ")" + labels +
                          R"(", "build": {"label": 4, "skin_vertices": 300}}},
                          {"name": "b", "model": {"input": ")" +
                          labels + R"(", "build": {"label": 4, "skin_vertices": 300}}}]})");
  r = run_lamina(dir, "run twice.json -o out");
  EXPECT_EQ(
      test::refusal_problems(r, {"twice.json: bodies 'a' and 'b' overlap"}, {"out"}, dir.path),
      std::vector<std::string>{});
  r = run_lamina(dir, "build " + data("liver_totalseg_example_3mm_labels.nii.gz") +
                          " --organ 1=liver,9=spleen -o organs");
  EXPECT_EQ(
      test::refusal_problems(r, {"organ 'spleen'", "no voxel of label 9"}, {"organs"}, dir.path),
      std::vector<std::string>{});
}

}  // namespace
}  // namespace lamina
