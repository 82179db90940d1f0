// `lamina resect` as a user runs it: the report, the files it writes (read back as 3D Slicer
// would read them), 3D Slicer's markups, and the inputs it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/label_volume_io.h"
#include "support/refusal.h"
#include "support/run_cli.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Dir : test::TempDir {
  fs::path work = path / "work";
  Dir() { fs::create_directories(work); }
};

test::RunResult lamina(const Dir& d, const std::string& args) {
  return test::run_cli(test::lamina_cli(), d.work, d.path, args);
}

void write(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

TEST(ResectCli, ThePhantomsPlanIsReportedAndWrittenForSlicer) {
  const Dir d;
  const auto r = lamina(d, "resect --plane 30,0,0:1,0,0 --margin 25 -o plan --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  const json file = json::parse(test::read_text(d.work / "plan" / "report.json"));
  EXPECT_EQ(j["volumes_ml"], file["volumes_ml"]);
  const double whole = j["volumes_ml"]["whole"], remnant = j["volumes_ml"]["remnant"];
  EXPECT_NEAR(j["future_liver_remnant"]["percent"].get<double>(), 100.0 * remnant / whole, 0.01);
  EXPECT_TRUE(j["future_liver_remnant"]["sufficient"].get<bool>());
  // The lesion is resected 20 mm from the plane: under the 25 mm asked, a finding.
  ASSERT_EQ(j["tumours"].size(), 2u);
  EXPECT_EQ(j["tumours"][1]["side"], "resected");
  EXPECT_FALSE(j["tumours"][1]["clear"].get<bool>());
  EXPECT_EQ(j["structures_crossed"].size(), 3u);
  bool said = false;
  for (const auto& f : j["findings"])
    said |= f.get<std::string>().find("under the 25.0 mm") != std::string::npos;
  EXPECT_TRUE(said) << j["findings"].dump();

  // The parts read back in ITK on the input's grid (the phantom's: lamina phantom --carved-out).
  ASSERT_EQ(lamina(d, "phantom --carved-out -o phantom.nii.gz").exit_code, 0);
  const LabelVolume input = io::read_label_volume((d.work / "phantom.nii.gz").string());
  const LabelVolume parts = io::read_label_volume((d.work / "plan" / "parts.nii.gz").string());
  EXPECT_EQ(parts.frame.size, input.frame.size);
  EXPECT_EQ(parts.frame.spacing_mm, input.frame.spacing_mm);
  EXPECT_EQ(parts.frame.origin_mm, input.frame.origin_mm);
  EXPECT_EQ(parts.frame.direction, input.frame.direction);
  int64_t counted[3] = {0, 0, 0};
  for (const int32_t l : parts.labels) ++counted[std::clamp(l, 0, 2)];
  EXPECT_EQ(counted[1], j["voxels_by_centre"]["remnant"].get<int64_t>());
  EXPECT_EQ(counted[2], j["voxels_by_centre"]["resected"].get<int64_t>());
  EXPECT_TRUE(fs::exists(d.work / "plan" / "surface.obj"));
  EXPECT_TRUE(fs::exists(d.work / "plan" / "surface.vtp"));
  // The picture (EGL, no display): a PNG, named in the report.
  const std::string png = test::read_text(d.work / "plan" / "resection.png");
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_EQ(file["outputs"]["picture"], "plan/resection.png");

  // The functional remnant (the phantom names its portal vein and hepatic veins): its volumes
  // add up, and the function and territories read back on the input's grid.
  const json& fr = j["functional_remnant"];
  ASSERT_TRUE(fr.is_object()) << j.dump();
  EXPECT_TRUE(fr["assessed"]["portal"].get<bool>());
  EXPECT_TRUE(fr["assessed"]["hepatic"].get<bool>());
  EXPECT_NEAR(fr["functional_ml"].get<double>(), remnant - fr["lost_ml"].get<double>(), 0.02);
  const LabelVolume function =
      io::read_label_volume((d.work / "plan" / "function.nii.gz").string());
  const LabelVolume portal =
      io::read_label_volume((d.work / "plan" / "territories.nii.gz").string());
  ASSERT_EQ(function.frame.size, input.frame.size);
  ASSERT_EQ(portal.frame.size, input.frame.size);
  int64_t lost = 0, in_remnant = 0;
  for (size_t v = 0; v < function.labels.size(); ++v) {
    EXPECT_EQ(function.labels[v] != 0, parts.labels[v] == 1) << "a remnant voxel has a function";
    EXPECT_EQ(portal.labels[v] != 0, parts.labels[v] != 0) << "an organ voxel has a territory";
    in_remnant += function.labels[v] != 0;
    lost += function.labels[v] > 1;
  }
  EXPECT_EQ(in_remnant, j["voxels_by_centre"]["remnant"].get<int64_t>());
  // The lost volume is the remnant's share of its voxels by centre.
  EXPECT_NEAR(remnant * static_cast<double>(lost) / static_cast<double>(in_remnant),
              fr["lost_ml"].get<double>(), 0.01);
}

TEST(ResectCli, AnObliqueGridsPartsKeepItsFrame) {
  // The TotalSegmentator example (direction diag(-1, -1, 1)), as NRRD.
  const Dir d;
  const std::string input = test::real_data("liver_totalseg_example_3mm_labels.nii.gz");
  const auto r = lamina(d, "resect " + test::quoted(input) +
                               " --label 1 --embed 2=portal_vein,3=vena_cava,4=gallbladder "
                               "--plane -66,-185,392:1,0.2,0 --format nrrd -o out --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const LabelVolume in = io::read_label_volume(input);
  const LabelVolume parts = io::read_label_volume((d.work / "out" / "parts.nrrd").string());
  EXPECT_EQ(parts.frame.size, in.frame.size);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(parts.frame.spacing_mm[a], in.frame.spacing_mm[a], 1e-9);
    EXPECT_NEAR(parts.frame.origin_mm[a], in.frame.origin_mm[a], 1e-6);
  }
  for (int e = 0; e < 9; ++e) EXPECT_NEAR(parts.frame.direction[e], in.frame.direction[e], 1e-9);
  // Every liver voxel is a part, and no other.
  for (size_t v = 0; v < in.labels.size(); ++v)
    if (in.labels[v] == 1) ASSERT_NE(parts.labels[v], 0) << v;
  const json j = json::parse(r.out);
  EXPECT_GT(j["volumes_ml"]["remnant"].get<double>(), 0.0);
  EXPECT_GT(j["volumes_ml"]["resected"].get<double>(), 0.0);
}

TEST(ResectCli, AModelIsPlannedFromItsOwnSurfaces) {
  // The phantom built with its anatomy embedded, then planned: the segmentation's plan within
  // the display skin's 1%, no parts file (a model has no grid), and --embed refused for it.
  const Dir d;
  ASSERT_EQ(lamina(d, "phantom --carved-out -o p.nii.gz").exit_code, 0);
  const auto b = lamina(d,
                        "build p.nii.gz --label 1 --embed 2=portal_vein,3=tumour,4=hepatic_veins "
                        "--display-triangles 30000 --structure-triangles 6000 -o m.vtu");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto seg =
      lamina(d,
             "resect p.nii.gz --label 1 --embed 2=portal_vein,3=tumour,4=hepatic_veins "
             "--plane 30.7,0,0:1,0,0 --json");
  const auto mod = lamina(d, "resect m.vtu --plane 30.7,0,0:1,0,0 --json -o plan");
  ASSERT_EQ(seg.exit_code, 0) << seg.err;
  ASSERT_EQ(mod.exit_code, 0) << mod.err;
  const json a = json::parse(seg.out), m = json::parse(mod.out);
  for (const char* part : {"remnant", "resected"})
    EXPECT_NEAR(m["volumes_ml"][part].get<double>(), a["volumes_ml"][part].get<double>(),
                0.01 * a["volumes_ml"][part].get<double>())
        << part;
  EXPECT_EQ(m["tumours"].size(), a["tumours"].size());
  EXPECT_EQ(m["structures_crossed"].size(), a["structures_crossed"].size());
  EXPECT_FALSE(m["structures_crossed"].empty());
  EXPECT_FALSE(m.contains("voxels_by_centre"));
  // The model carries the portal and hepatic trees (issue 63): its functional remnant is the
  // segmentation's (docs/resection.md), given as numbers; no volume is written for a model.
  ASSERT_FALSE(m["functional_remnant"].is_null()) << mod.out;
  EXPECT_NEAR(m["functional_remnant"]["percent"].get<double>(),
              a["functional_remnant"]["percent"].get<double>(), 0.5);
  EXPECT_FALSE(fs::exists(d.work / "plan" / "function.nii.gz"));
  EXPECT_TRUE(fs::exists(d.work / "plan" / "report.json"));

  // The same anatomy as separate masks beside the organ's own label (issue 61: masks were
  // embedded as label 0, read as the display skin, and the plan reported none of them): the
  // same findings.
  {
    const LabelVolume v = geometry::make_phantom({.carved_out = true});
    const auto write_only = [&](int32_t label, const char* file) {
      LabelVolume m = v;
      for (int32_t& l : m.labels) l = l == label ? 1 : 0;
      io::write_label_volume(m, (d.work / file).string());
    };
    write_only(1, "organ.nii.gz");
    write_only(2, "portal.nii.gz");
    write_only(3, "tumour.nii.gz");
    write_only(4, "hepatic.nii.gz");
  }
  const auto bm =
      lamina(d,
             "build organ.nii.gz --embed-mask portal.nii.gz=portal_vein "
             "--embed-mask tumour.nii.gz=tumour --embed-mask hepatic.nii.gz=hepatic_veins "
             "--display-triangles 30000 --structure-triangles 6000 -o masks.vtu");
  ASSERT_EQ(bm.exit_code, 0) << bm.err;
  const auto masks = lamina(d, "resect masks.vtu --plane 30.7,0,0:1,0,0 --json");
  ASSERT_EQ(masks.exit_code, 0) << masks.err;
  const json k = json::parse(masks.out);
  for (const char* part : {"remnant", "resected"})
    EXPECT_NEAR(k["volumes_ml"][part].get<double>(), m["volumes_ml"][part].get<double>(),
                0.005 * m["volumes_ml"][part].get<double>())
        << part;
  ASSERT_EQ(k["tumours"].size(), m["tumours"].size());
  const double diagonal = 1.5 * std::sqrt(3.0);
  for (size_t t = 0; t < m["tumours"].size(); ++t) {
    EXPECT_EQ(k["tumours"][t]["side"], m["tumours"][t]["side"]);
    EXPECT_NEAR(k["tumours"][t]["margin_mm"].get<double>(),
                m["tumours"][t]["margin_mm"].get<double>(), diagonal);
  }
  ASSERT_EQ(k["structures_crossed"].size(), m["structures_crossed"].size());
  for (size_t c = 0; c < m["structures_crossed"].size(); ++c) {
    EXPECT_EQ(k["structures_crossed"][c]["name"], m["structures_crossed"][c]["name"]);
    EXPECT_EQ(k["structures_crossed"][c]["role"], "vessel");
    EXPECT_NEAR(k["structures_crossed"][c]["diameter_mm"].get<double>(),
                m["structures_crossed"][c]["diameter_mm"].get<double>(), 1.0);
  }
  EXPECT_EQ(k["findings"].size(), m["findings"].size());
  EXPECT_FALSE(fs::exists(d.work / "plan" / "parts.nii.gz"));
  EXPECT_TRUE(fs::exists(d.work / "plan" / "report.json"));
  const auto refused = lamina(d, "resect m.vtu --embed 2=x --plane 30,0,0:1,0,0 -o out");
  const auto problems = test::refusal_problems(refused, {"m.vtu", "--embed"}, {"out"}, d.work);
  EXPECT_TRUE(problems.empty()) << test::as_list(problems) << refused.err;
}

TEST(ResectCli, SlicerMarkupsGiveTheSamePlanAsThePlane) {
  const Dir d;
  // The plane x = 30 (LPS) as Slicer writes it in RAS: centre and normal; then a closed curve
  // around the organ in that plane; then one control point with its axes.
  write(d.work / "plane.mrk.json",
        R"({"markups": [{"type": "Plane", "coordinateSystem": "RAS", "planeType": "pointNormal",
            "center": [-30.0, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0],
            "controlPoints": [{"position": [-30.0, 0.0, 0.0]}]}]})");
  write(d.work / "curve.mrk.json",
        R"({"markups": [{"type": "ClosedCurve", "coordinateSystem": "LPS", "controlPoints": [
            {"position": [30, -200, -200]}, {"position": [30, 200, -200]},
            {"position": [30, 200, 200]}, {"position": [30, -200, 200]}]}]})");
  write(d.work / "axes.mrk.json",
        R"({"markups": [{"type": "Plane", "coordinateSystem": "LPS",
            "baseToNode": [0, 0, 1, 0,  0, 1, 0, 0,  -1, 0, 0, 0,  0, 0, 0, 1],
            "controlPoints": [{"position": [30, 0, 0]}]}]})");
  const auto plane = lamina(d, "resect --plane 30,0,0:1,0,0 --json");
  ASSERT_EQ(plane.exit_code, 0) << plane.err;
  const json expected = json::parse(plane.out)["volumes_ml"];
  // And the sheet x = 30 as VTK's writer saves a model (appended, base64, zlib; what 3D Slicer
  // writes for .vtp), and as raw big-endian triangle data (tests/io/vtp).
  const std::string sheet = test::quoted(test::source_path("tests/io/vtp/default.vtp").string());
  const std::string raw =
      test::quoted(test::source_path("tests/io/vtp/raw_big_endian.vtp").string());
  for (const std::string& file : {std::string("plane.mrk.json"), std::string("curve.mrk.json"),
                                  std::string("axes.mrk.json"), sheet, raw}) {
    const auto r = lamina(d, "resect --surface " + file + " --json");
    ASSERT_EQ(r.exit_code, 0) << file << ": " << r.err;
    EXPECT_EQ(json::parse(r.out)["volumes_ml"], expected) << file;
  }
}

TEST(ResectCli, CouinaudsSegmentsAreWrittenOnTheInputsGridWhenAsked) {
  const Dir d;
  const auto r = lamina(d, "resect --plane 5,0,0:1,0,0 --segments -o plan --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  ASSERT_TRUE(j["couinaud_segments"].is_object()) << j.dump();
  // The phantom's portal vein and hepatic veins are two labels: their landmarks place them.
  EXPECT_EQ(j["couinaud_segments"]["placed_by"], "vessels");
  EXPECT_TRUE(j["couinaud_segments"]["vessels_not_used"].is_null());
  const LabelVolume parts = io::read_label_volume((d.work / "plan" / "parts.nii.gz").string());
  const LabelVolume segments =
      io::read_label_volume((d.work / "plan" / "segments.nii.gz").string());
  ASSERT_EQ(segments.frame.size, parts.frame.size);
  // Every organ voxel in one segment 1-8; per segment, the share the parts say is resected.
  int64_t in[9] = {}, resected[9] = {};
  for (size_t v = 0; v < parts.labels.size(); ++v) {
    const int32_t s = segments.labels[v];
    ASSERT_EQ(s != 0, parts.labels[v] != 0);
    ASSERT_LE(s, 8);
    ++in[s];
    resected[s] += parts.labels[v] == 2;
  }
  double sum = 0.0;
  for (int s = 1; s <= 8; ++s) {
    const json& seg = j["couinaud_segments"]["segments"][s - 1];
    sum += seg["volume_ml"].get<double>();
    if (in[s] > 0)
      EXPECT_NEAR(seg["resected_percent"].get<double>(),
                  100.0 * static_cast<double>(resected[s]) / static_cast<double>(in[s]), 0.01)
          << "segment " << s;
  }
  EXPECT_NEAR(sum, j["volumes_ml"]["whole"].get<double>(), 0.002 * sum);
}

TEST(ResectCli, CouinaudsSegmentsFromOneMergedVesselLabelArePlacedByTheAtlas) {
  const Dir d;
  // A vessel label named as both trees: auto takes the atlas, which agrees with experts
  // better than the landmarks of a merged tree (docs/resection.md).
  const std::string merged =
      "resect --plane 5,0,0:1,0,0 --label 1 --embed "
      "2=liver_vessels,4=hepatic_veins --segments --json";
  const auto a = lamina(d, merged);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const json ja = json::parse(a.out);
  EXPECT_EQ(ja["couinaud_segments"]["placed_by"], "atlas");
  // Asked for explicitly: the phantom's two trees placed by the atlas as well.
  const auto b =
      lamina(d,
             "resect --plane 5,0,0:1,0,0 --label 1 --embed 2=portal_vein,4=hepatic_veins "
             "--segments --segments-from atlas --json");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const json jb = json::parse(b.out);
  EXPECT_EQ(jb["couinaud_segments"]["placed_by"], "atlas");
  // The same organ, the same atlas: the same segments.
  for (int s = 0; s < 8; ++s)
    EXPECT_EQ(ja["couinaud_segments"]["segments"][s]["volume_ml"],
              jb["couinaud_segments"]["segments"][s]["volume_ml"])
        << "segment " << s + 1;
  EXPECT_EQ(jb["couinaud_segments"]["atlas"]["livers"].size(), 10U);
  EXPECT_TRUE(jb["couinaud_segments"]["landmarks"].is_null());
  // With vessels among the structures the atlas lines its livers' vessels up with them.
  EXPECT_EQ(ja["couinaud_segments"]["atlas"]["vessels_lined_up"], true);
  EXPECT_EQ(jb["couinaud_segments"]["atlas"]["vessels_lined_up"], true);
  // The atlas needs only the organ: no structure named at all.
  const auto alone =
      lamina(d, "resect --plane 5,0,0:1,0,0 --label 1 --segments --segments-from atlas --json");
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const json jo = json::parse(alone.out);
  EXPECT_EQ(jo["couinaud_segments"]["placed_by"], "atlas");
  EXPECT_EQ(jo["couinaud_segments"]["atlas"]["vessels_lined_up"], false);
  // The vessels asked for where the merged label (the portal vein alone) has no landmarks:
  // refused, naming what is missing.
  const auto c = lamina(d,
                        "resect --plane 5,0,0:1,0,0 --label 1 --embed 2=liver_vessels "
                        "--segments --segments-from vessels");
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("upper quarter"), std::string::npos) << c.err;
}

TEST(ResectCli, RefusesBadSurfacesWithOneLineAndWritesNothing) {
  const Dir d;
  write(d.work / "open.mrk.json",
        R"({"markups": [{"type": "Curve", "controlPoints": [{"position": [0, 0, 0]},
            {"position": [1, 0, 0]}, {"position": [1, 1, 0]}]}]})");
  write(d.work / "points.mrk.json",
        R"({"markups": [{"type": "Fiducial", "controlPoints": [{"position": [0, 0, 0]}]}]})");
  write(d.work / "broken.mrk.json", R"({"markups": [{"type": "Plane", )");
  write(d.work / "flat.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n");
  write(d.work / "cut.vtp",
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\"><PolyData>"
        "<Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">");
  struct Case {
    std::string args;
    std::vector<std::string> says;
  };
  const Case cases[] = {
      {"--plane 0,0,500:0,0,1", {"misses the organ"}},
      {"--plane 0,0,0:0,0,0", {"--plane", "zero length"}},
      {"--plane 0,0,0", {"--plane", "POINT:NORMAL"}},
      {"--plane 0,0,x:1,0,0", {"--plane", "three numbers"}},
      {"--surface open.mrk.json", {"open.mrk.json", "not closed"}},
      {"--surface points.mrk.json", {"points.mrk.json", "Fiducial"}},
      {"--surface broken.mrk.json", {"broken.mrk.json", "JSON"}},
      {"--surface flat.obj", {"flat.obj", "degenerate"}},
      {"--surface missing.ply", {"missing.ply", "not found"}},
      {"--surface plan.vtk", {"plan.vtk", "unsupported"}},
      {"--surface cut.vtp", {"cut.vtp", "truncated"}},
      {"", {"--plane", "--surface"}},
      {"--plane 0,0,0:1,0,0 --keep 0,5,5", {"--keep", "on the resection surface"}},
      {"--plane 0,0,0:1,0,0 --embed 9=bile", {"label 9"}},
      // Couinaud's segments without vessels named to read them from.
      {"--plane 0,0,0:1,0,0 --label 1 --embed 2=vessel,3=tumour,4=veins,5=cava --segments",
       {"segments need"}},
      // The vena cava (outside the organ) named as the portal vein: no tree to follow.
      {"--plane 0,0,0:1,0,0 --label 1 --embed 2=bile_duct,3=tumour,4=hepatic_veins,5=portal_vein",
       {"portal_vein", "inside the organ"}},
  };
  for (const Case& c : cases) {
    const auto r = lamina(d, "resect " + c.args + " -o out");
    const auto problems = test::refusal_problems(r, c.says, {"out"}, d.work);
    EXPECT_TRUE(problems.empty()) << "lamina resect " << c.args << ":\n"
                                  << test::as_list(problems) << r.err;
  }
}

}  // namespace
}  // namespace lamina
