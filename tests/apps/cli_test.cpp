// End-to-end tests of the `lamina` tool: the real binary (`test::lamina_cli()`) runs in a fresh
// folder with stdout and stderr captured in files, so exit codes, messages and leftover files are
// exactly what a user or a script would see.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
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

// A fresh folder per test: `work` is where inputs and outputs go (and must hold nothing
// unexpected afterwards); the captured streams live beside it, not in it.
// Inputs and outputs go in work/; captured stdout and stderr beside it, so that checks for
// stray files in work/ see only what lamina wrote.
struct TempDir : lamina::test::TempDir {
  fs::path& root = path;
  fs::path work = path / "work";
  TempDir() { fs::create_directories(work); }
  std::string file(const std::string& name) const { return (work / name).string(); }
};

using test::quoted;
using test::RunResult;

std::string read_file(const fs::path& path) {
  return test::read_text(path);
}

void write_file(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// Runs `lamina ARGS` with `dir` as working directory.
RunResult run_lamina(const TempDir& dir, const std::string& args) {
  return test::run_cli(test::lamina_cli(), dir.work, dir.root, args);
}

// A MetaImage file: a text header, then the raw voxels ("ElementDataFile = LOCAL").
void write_mha(const fs::path& path, const std::string& header_fields, const std::string& voxels) {
  write_file(path, "ObjectType = Image\n" + header_fields + "ElementDataFile = LOCAL\n" + voxels);
}

// An n^3 uint8 volume holding a cube of ones with a one-voxel-thick background border, so
// that it is a valid mask whatever the header says about spacing.
std::string cube_voxels(int n) {
  std::string v(static_cast<size_t>(n * n * n), '\0');
  for (int k = 1; k < n - 1; ++k)
    for (int j = 1; j < n - 1; ++j)
      for (int i = 1; i < n - 1; ++i) v[static_cast<size_t>(i + n * (j + n * k))] = 1;
  return v;
}

LabelVolume cube_volume(int64_t n, int32_t label) {
  LabelVolume v;
  v.frame.size = {n, n, n};
  v.frame.spacing_mm = {2.0, 2.0, 2.0};
  v.labels.assign(static_cast<size_t>(n * n * n), 0);
  for (int64_t k = 2; k < n - 2; ++k)
    for (int64_t j = 2; j < n - 2; ++j)
      for (int64_t i = 2; i < n - 2; ++i) v.labels[v.frame.index(i, j, k)] = label;
  return v;
}

// The phantom at 3 mm: a valid input that reads and builds in well under a second.
std::string write_small_phantom(const TempDir& dir, const std::string& name) {
  const std::string path = dir.file(name);
  io::write_label_volume(geometry::make_phantom({.spacing_mm = {3.0, 3.0, 3.0}}), path);
  return path;
}

// Builds a small model with the tool itself (quietly), for the `info` and `export` cases.
std::string build_small_model(const TempDir& dir, const std::string& name) {
  const std::string input = write_small_phantom(dir, "model_input.nii.gz");
  const RunResult r = run_lamina(
      dir, "-q build " + quoted(input) + " -o " + quoted(dir.file(name)) + " --skin-vertices 300");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  fs::remove(input);
  return dir.file(name);
}

void truncate_to_half(const std::string& path) {
  const std::string bytes = read_file(path);
  write_file(path, bytes.substr(0, bytes.size() / 2));
}

// ---------------------------------------------------------------------------------------------
// Unusable input: every case must end with exit code 2, one "lamina: error: " line naming the
// input and the problem, and no output or temporary file.

struct BadCase {
  std::string name;
  /// Creates the bad input in the test folder; returns the arguments for `lamina`.
  std::function<std::string(const TempDir&)> setup;
  /// Every one of these must appear in the message (case-insensitive): the input's name and
  /// the word that tells the user what is wrong.
  std::vector<std::string> message_has;
  /// Files that must not exist afterwards (relative to the test folder).
  std::vector<std::string> no_output = {"OUT.vtu"};
};

std::string build_args(const TempDir& dir, const std::string& input,
                       const std::string& extra = "") {
  return "build " + quoted(dir.file(input)) + " -o " + quoted(dir.file("OUT.vtu")) +
         (extra.empty() ? "" : " " + extra);
}

std::vector<BadCase> bad_cases() {
  std::vector<BadCase> c;
  c.push_back({"MissingFile",
               [](const TempDir& d) { return build_args(d, "absent.nii.gz"); },
               {"absent.nii.gz", "no such"}});
  c.push_back({"FolderWithoutDicom",
               [](const TempDir& d) {
                 fs::create_directory(d.work / "scans");
                 write_file(d.work / "scans" / "notes.txt", "not a DICOM slice\n");
                 return build_args(d, "scans");
               },
               {"scans", "dicom"}});
  c.push_back({"RandomBytesNamedNiiGz",
               [](const TempDir& d) {
                 std::mt19937 rng(7);
                 std::string bytes(4096, '\0');
                 for (char& b : bytes) b = static_cast<char>(rng());
                 write_file(d.work / "x.nii.gz", bytes);
                 return build_args(d, "x.nii.gz");
               },
               {"x.nii.gz", "read"}});
  c.push_back({"GarbageTextNamedNrrd",
               [](const TempDir& d) {
                 write_file(d.work / "x.nrrd", "this is not an image\nat all\n");
                 return build_args(d, "x.nrrd");
               },
               {"x.nrrd", "read"}});
  // Each format is cut differently: raw voxels (.nii), a gzip stream (.nii.gz, and .nrrd and
  // .mha, which write_label_volume compresses).
  for (const std::string ext : {"nii", "nii.gz", "nrrd", "mha"}) {
    std::string tag = ext;
    std::replace(tag.begin(), tag.end(), '.', '_');
    c.push_back({"PhantomCutInHalf_" + tag,
                 [ext](const TempDir& d) {
                   const std::string path = write_small_phantom(d, "half." + ext);
                   truncate_to_half(path);
                   return build_args(d, "half." + ext);
                 },
                 {"half." + ext, "truncated"}});
  }
  c.push_back({"MetaImageShorterThanItsHeader",
               [](const TempDir& d) {
                 write_mha(d.work / "short.mha",
                           "NDims = 3\nDimSize = 40 40 40\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 1 1\n",
                           cube_voxels(10));
                 return build_args(d, "short.mha");
               },
               {"short.mha", "truncated"}});
  c.push_back({"TwoDimensionalImage",
               [](const TempDir& d) {
                 write_mha(d.work / "flat.mha",
                           "NDims = 2\nDimSize = 4 4\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 1\n",
                           std::string(16, '\1'));
                 return build_args(d, "flat.mha");
               },
               {"flat.mha", "2-D"}});
  c.push_back({"FourDimensionalImage",
               [](const TempDir& d) {
                 write_mha(d.work / "time.mha",
                           "NDims = 4\nDimSize = 6 6 6 2\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 1 1 1\n",
                           cube_voxels(6) + cube_voxels(6));
                 return build_args(d, "time.mha");
               },
               {"time.mha", "4-D"}});
  c.push_back({"EmptyMask",
               [](const TempDir& d) {
                 io::write_label_volume(cube_volume(10, 0), d.file("empty.nii.gz"));
                 return build_args(d, "empty.nii.gz");
               },
               {"empty.nii.gz", "empty"}});
  c.push_back({"AbsentLabel",
               [](const TempDir& d) {
                 io::write_label_volume(cube_volume(10, 1), d.file("one_label.nii.gz"));
                 return build_args(d, "one_label.nii.gz", "--label 7");
               },
               // The message must say which labels there are, so the user can pick one.
               {"one_label.nii.gz", "label 7", "absent", "present: 1"}});
  c.push_back({"OneVoxelMask",
               [](const TempDir& d) {
                 LabelVolume v = cube_volume(9, 0);
                 v.labels[v.frame.index(4, 4, 4)] = 1;
                 io::write_label_volume(v, d.file("dot.nii.gz"));
                 return build_args(d, "dot.nii.gz");
               },
               {"dot.nii.gz", "voxel"}});
  // ITK refuses a zero spacing itself, and turns a negative one into a positive spacing with a
  // mirrored direction; neither may reach the model as if the header were sound.
  c.push_back({"ZeroSpacing",
               [](const TempDir& d) {
                 write_mha(d.work / "zero.mha",
                           "NDims = 3\nDimSize = 8 8 8\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 0 1\n",
                           cube_voxels(8));
                 return build_args(d, "zero.mha");
               },
               {"zero.mha", "spacing"}});
  c.push_back({"NegativeSpacing",
               [](const TempDir& d) {
                 write_mha(d.work / "negative.mha",
                           "NDims = 3\nDimSize = 8 8 8\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 -1 1\n",
                           cube_voxels(8));
                 return build_args(d, "negative.mha");
               },
               {"negative.mha", "spacing"}});
  c.push_back({"ThreeComponentsPerVoxel",
               [](const TempDir& d) {
                 const std::string cube = cube_voxels(6);
                 write_mha(d.work / "rgb.mha",
                           "NDims = 3\nDimSize = 6 6 6\nElementType = MET_UCHAR\n"
                           "ElementNumberOfChannels = 3\nElementSpacing = 1 1 1\n",
                           cube + cube + cube);
                 return build_args(d, "rgb.mha");
               },
               {"rgb.mha", "components"}});
  // A corrupt header can claim terabytes; the tool must refuse before allocating them.
  c.push_back({"HeaderClaimsTooManyVoxels",
               [](const TempDir& d) {
                 write_mha(d.work / "huge.mha",
                           "NDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_UCHAR\n"
                           "ElementSpacing = 1 1 1\n",
                           cube_voxels(4));
                 return build_args(d, "huge.mha");
               },
               {"huge.mha", "voxels"}});
  c.push_back({"NotANumberInFloatMask",
               [](const TempDir& d) {
                 std::vector<float> v(6 * 6 * 6, 0.0f);
                 v[100] = std::numeric_limits<float>::quiet_NaN();
                 write_mha(d.work / "nan.mha",
                           "NDims = 3\nDimSize = 6 6 6\nElementType = MET_FLOAT\n"
                           "ElementSpacing = 1 1 1\nBinaryDataByteOrderMSB = False\n",
                           std::string(reinterpret_cast<const char*>(v.data()), v.size() * 4));
                 return build_args(d, "nan.mha");
               },
               {"nan.mha", "non-finite"}});

  // Bad options, with a valid input so that only the option can be at fault.
  c.push_back({"ZeroLayers",
               [](const TempDir& d) {
                 write_small_phantom(d, "p.nii.gz");
                 return build_args(d, "p.nii.gz", "--layers 0");
               },
               {"--layers", "0"}});
  c.push_back({"ThreeSkinVertices",
               [](const TempDir& d) {
                 write_small_phantom(d, "p.nii.gz");
                 return build_args(d, "p.nii.gz", "--skin-vertices 3");
               },
               {"--skin-vertices", "3"}});
  c.push_back({"TextOutputExtension",
               [](const TempDir& d) {
                 write_small_phantom(d, "p.nii.gz");
                 return "build " + quoted(d.file("p.nii.gz")) + " -o " + quoted(d.file("OUT.txt"));
               },
               {"OUT.txt", ".vtu"},
               {"OUT.txt", "OUT.vtu"}});

  // `info` and `export`.
  c.push_back({"InfoOnMissingModel",
               [](const TempDir& d) { return "info " + quoted(d.file("nowhere.vtu")); },
               {"nowhere.vtu", "not found"},
               {}});
  c.push_back({"InfoOnTruncatedModel",
               [](const TempDir& d) {
                 truncate_to_half(build_small_model(d, "cut.vtu"));
                 return "info " + quoted(d.file("cut.vtu"));
               },
               {"cut.vtu", "truncated"},
               {}});
  c.push_back({"ExportLayerOutOfRange",
               [](const TempDir& d) {
                 build_small_model(d, "m.vtu");
                 return "export " + quoted(d.file("m.vtu")) + " -o " + quoted(d.file("e.obj")) +
                        " --layer 2";
               },
               {"--layer", "2"},
               {"e.obj"}});
  c.push_back({"ExportNegativeLayer",
               [](const TempDir& d) {
                 build_small_model(d, "m.vtu");
                 return "export " + quoted(d.file("m.vtu")) + " -o " + quoted(d.file("e.stl")) +
                        " --layer -1";
               },
               {"--layer", "-1"},
               {"e.stl"}});
  // Found by fuzz_volume: ITK 5.2's MetaIO dies of SIGFPE (exit 136) on a slice-file pattern
  // whose step is 0. Lamina refuses such patterns before ITK reads the data.
  c.push_back({"MetaImageFilePatternThatKilledItk",
               [](const TempDir& d) {
                 write_file(d.work / "pattern.mha",
                            "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                            "ElementType = MET_UCHAR\nElementSpacing = 1 1 1\n"
                            "ElementDataFile = slice%03d.raw 1 4 0\n");
                 return build_args(d, "pattern.mha");
               },
               {"pattern.mha", "ElementDataFile"}});
  c.push_back({"VolumeOverTheConfiguredVoxelBudget",
               [](const TempDir& d) {
                 write_small_phantom(d, "p.nii.gz");
                 return "--max-voxels 1000 " + build_args(d, "p.nii.gz");
               },
               {"p.nii.gz", "limit of 1000", "--max-voxels"}});
  // A model whose every value is valid but one was changed after saving: only its checksum can
  // tell.
  c.push_back({"InfoOnModelEditedAfterSaving",
               [](const TempDir& d) {
                 const std::string path = build_small_model(d, "edited.vtu");
                 std::string text = read_file(path);
                 size_t at = text.find(">", text.find("Name=\"Points\"")) + 1;
                 while (!std::isdigit(static_cast<unsigned char>(text[at]))) ++at;
                 text[at] = text[at] == '9' ? '8' : static_cast<char>(text[at] + 1);
                 write_file(path, text);
                 return "info " + quoted(path);
               },
               {"edited.vtu", "checksum"},
               {}});
  c.push_back({"InfoOnModelOfAnotherVersion",
               [](const TempDir& d) {
                 const std::string path = build_small_model(d, "future.vtu");
                 std::string text = read_file(path);
                 const size_t name = text.find("Name=\"lamina_format_version\"");
                 const size_t value = text.find(">", name) + 1;
                 text.replace(value, text.find("<", value) - value, "\n99\n");
                 write_file(path, text);
                 return "info " + quoted(path);
               },
               {"future.vtu", "version 99"},
               {}});

  // Scenes: each must be refused before the model is built or the output folder made.
  const auto scene_case = [&](const std::string& name, const std::string& text,
                              std::vector<std::string> message) {
    c.push_back({name,
                 [text](const TempDir& d) {
                   write_file(d.work / "scene.json", text);
                   return "run " + quoted(d.file("scene.json")) + " -o " + quoted(d.file("out"));
                 },
                 std::move(message),
                 {"out"}});
  };
  scene_case("SceneInvalidJson", "{\"solver\": {\"dt_s\": 0.01,,}}", {"scene.json", "JSON"});
  scene_case("SceneWrongType", R"({"solver": {"dt_s": "fast"}})", {"scene.json", "solver.dt_s"});
  scene_case("SceneNegativeDt", R"({"solver": {"dt_s": -0.01}})", {"scene.json", "solver.dt_s"});
  scene_case("SceneNegativeStiffness", R"({"material": {"stiffness_n_per_m": -3}})",
             {"scene.json", "material.stiffness_n_per_m"});
  scene_case("SceneLocalityZero", R"({"solver": {"locality": 0}})", {"scene.json", "locality"});
  scene_case("SceneInfiniteForce", R"({"tools": [{"vertex": 0, "force_n": [0, 1e999, 0]}]})",
             {"scene.json", "1e999"});
  scene_case("SceneMissingModelFile", R"({"model": {"model": "nowhere.vtu"}})", {"nowhere.vtu"});
  scene_case("SceneEmbedOfAnUnknownRole",
             R"({"model": {"build": {"embed": [{"label": 2, "name": "pv", "role": "wound"}]}}})",
             {"scene.json", "model.build.embed[0].role", "wound"});
  // A structure's role (issue 61): only what a structure is.
  c.push_back({"BuildEmbedOfAnUnknownRole",
               [](const TempDir& d) {
                 io::write_label_volume(
                     geometry::make_phantom({.spacing_mm = {4, 4, 4}, .anatomy = true}),
                     d.file("a.nii.gz"));
                 return "build " + quoted(d.file("a.nii.gz")) + " -o " + quoted(d.file("a.vtu")) +
                        " --embed 2=pv:artery";
               },
               {"--embed", "'2=pv:artery'", "not a role"},
               {"a.vtu"}});

  // Checkpoints (lamina run --resume).
  c.push_back({"ResumeFromAFileThatIsNotACheckpoint",
               [](const TempDir& d) {
                 write_file(d.work / "ck.lmck", "LAMCKPT\nbut not really");
                 return "run -o " + quoted(d.file("out")) + " --resume " +
                        quoted(d.file("ck.lmck"));
               },
               {"ck.lmck", "checkpoint"},
               {"out"}});
  return c;
}

// gtest prints a failing parameter; the case name is what identifies it.
void PrintTo(const BadCase& c, std::ostream* os) {
  *os << c.name;
}

class BadInput : public ::testing::TestWithParam<BadCase> {};

// All of a case's problems are collected into one failure, so the report shows at a glance
// everything that is wrong with one run, with its stderr once.
TEST_P(BadInput, FailsWithOneLineExitTwoAndNoFiles) {
  const BadCase& bad = GetParam();
  TempDir dir;
  const std::string args = bad.setup(dir);
  const RunResult r = run_lamina(dir, args);

  const std::vector<std::string> problems =
      test::refusal_problems(r, bad.message_has, bad.no_output, dir.work);
  const std::string report = test::as_list(problems);
  EXPECT_TRUE(problems.empty()) << "lamina " << args << "\n" << report << "stderr was:\n" << r.err;
}

INSTANTIATE_TEST_SUITE_P(Cli, BadInput, ::testing::ValuesIn(bad_cases()),
                         [](const auto& info) { return info.param.name; });

// Options are checked before the input is read: with a missing input, the message must still
// be about the option (a typo must not cost a long read of a large scan first).
TEST(CliOptions, OptionErrorsComeBeforeReadingTheInput) {
  TempDir dir;
  for (const std::string option : {"--layers 0", "--skin-vertices 3", "--locality 0"}) {
    SCOPED_TRACE(option);
    const RunResult r = run_lamina(dir, build_args(dir, "absent.nii.gz", option));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(option.substr(0, option.find(' '))), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("absent.nii.gz"), std::string::npos) << r.err;
  }
}

// Every subcommand's --help is text a terminal shows as written: printable ASCII and line
// breaks (an enum option once printed its values' raw bytes), exit 0.
TEST(CliOptions, EveryHelpIsPrintableText) {
  TempDir dir;
  // The subcommands as the tool lists them, so that a new one is checked too.
  std::vector<std::string> subs = {""};
  {
    const RunResult top = run_lamina(dir, "--help");
    std::istringstream in(top.out.substr(std::min(top.out.find("Subcommands:"), top.out.size())));
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line))
      if (line.starts_with("  ") && line.size() > 2 && line[2] != ' ')
        subs.push_back(line.substr(2, line.find(' ', 2) - 2));
  }
  ASSERT_GE(subs.size(), 12u) << "subcommands not found in lamina --help";
  for (const std::string& sub : subs) {
    SCOPED_TRACE(sub);
    const RunResult r = run_lamina(dir, sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_GT(r.out.size(), 100u);
    const auto bad = std::find_if(r.out.begin(), r.out.end(), [](unsigned char c) {
      return c != '\n' && (c < 0x20 || c > 0x7e);
    });
    EXPECT_EQ(bad, r.out.end()) << "byte " << static_cast<int>(static_cast<unsigned char>(*bad))
                                << " at " << (bad - r.out.begin());
  }
}

// ---------------------------------------------------------------------------------------------
// The documented workflow: phantom -> build -> info -> export.

// Counts the lines of an OBJ file that start with `tag` ("v " or "f ").
int64_t count_obj_lines(const std::string& text, const std::string& tag) {
  int64_t n = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) n += line.starts_with(tag);
  return n;
}

TEST(CliWorkflow, APhantomWithLabelsCarriesItsAnatomyAndBuildsTheSameOrgan) {
  TempDir dir;
  RunResult r = run_lamina(dir, "phantom --labels -o A.nii.gz --spacing 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("labels: 1 liver"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 vessel tree"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("3 tumour"), std::string::npos) << r.err;
  const LabelVolume v = io::read_label_volume((dir.work / "A.nii.gz").string());
  int64_t count[4] = {0, 0, 0, 0};
  for (int32_t l : v.labels) {
    ASSERT_GE(l, 0);
    ASSERT_LE(l, 3);
    ++count[l];
  }
  EXPECT_GT(count[2], 0);
  EXPECT_GT(count[3], 0);
  // Any non-zero voxel is the organ: it builds as the plain phantom does.
  r = run_lamina(dir, "build A.nii.gz -o A.vtu --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  write_small_phantom(dir, "P.nii.gz");
  const RunResult plain = run_lamina(dir, "build P.nii.gz -o P.vtu --json");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(json::parse(r.out).at("nodes"), json::parse(plain.out).at("nodes"));
}

// Issue 33: `lamina build --embed` makes the display skin and the structures, the model file
// keeps them (info lists them), and a bad embedding writes nothing and exits 2.
TEST(CliWorkflow, BuildEmbedsTheAnatomyAndRefusesBadEmbeddings) {
  TempDir dir;
  ASSERT_EQ(run_lamina(dir, "phantom --labels -o A.nii.gz --spacing 3").exit_code, 0);
  RunResult r = run_lamina(dir,
                           "build A.nii.gz -o A.vtu --json --display-triangles 4000 "
                           "--structure-triangles 1000 --embed 2=vessels,3=tumour");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json built = json::parse(r.out).at("embedded");
  ASSERT_EQ(built.size(), 3u) << r.out;
  EXPECT_EQ(built[0].at("name"), "display_skin");
  EXPECT_NEAR(built[0].at("faces").get<double>(), 4000.0, 0.05 * 4000.0);
  EXPECT_EQ(built[1].at("name"), "vessels");
  EXPECT_EQ(built[2].at("name"), "tumour");
  EXPECT_EQ(built[2].at("outside"), 0);
  r = run_lamina(dir, "info A.vtu --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out).at("embedded"), built);

  const char* bad[][2] = {
      {"--embed 7=portal", "label 7"},
      {"--label 1 --embed 1", "every voxel selected as the organ is an embedded"},
      {"--embed 2=pv:artery", "not a role"},
      {"--embed two", "--embed"},
      {"--embed-mask missing.nii.gz", "missing.nii.gz"},
      {"--structure links --embed 2", "tetrahedra"}};
  for (const auto& [args, says] : bad) {
    r = run_lamina(dir, std::string("build A.nii.gz -o B.vtu ") + args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir.work / "B.vtu")) << args;
  }
}

// Issue 46: the carved-out phantom (each voxel liver or a structure, the vessels leaving the
// organ) builds with --label 1 and its structures embedded: the organ whole, each structure
// reported, none amplifying its tetrahedron's motion; an organ of structures alone is refused.
TEST(CliWorkflow, ACarvedOutLabelMapBuildsWithItsStructuresEmbedded) {
  TempDir dir;
  RunResult r = run_lamina(dir, "phantom --carved-out -o C.nii.gz --spacing 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("5 vena cava"), std::string::npos) << r.err;
  r = run_lamina(dir,
                 "build C.nii.gz -o C.vtu --json --label 1 --display-triangles 4000 "
                 "--structure-triangles 1000 "
                 "--embed 2=portal_vein,3=tumours,4=hepatic_veins,5=vena_cava");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json built = json::parse(r.out);
  const json& structures = built.at("mask").at("structures");
  ASSERT_EQ(structures.size(), 4u) << r.out;
  EXPECT_EQ(structures[3].at("name"), "vena_cava");
  EXPECT_LT(structures[3].at("inside_organ").get<int64_t>(),
            structures[3].at("voxels").get<int64_t>() / 2);
  EXPECT_GT(built.at("mask").at("structure_voxels_taken_in").get<int64_t>(), 0);
  for (const json& e : built.at("embedded")) EXPECT_LE(e.at("max_amplification"), 2.0) << e;
  EXPECT_GT(built.at("embedded")[4].at("offset").get<int64_t>(), 0);
  r = run_lamina(dir, "build C.nii.gz -o D.vtu --embed 1=a,2=b,3=c,4=d,5=e");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("every voxel selected as the organ is an embedded structure's"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir.work / "D.vtu"));
}

TEST(CliWorkflow, PhantomBuildInfoExport) {
  TempDir dir;
  RunResult r = run_lamina(dir, "phantom -o P.nii.gz --spacing 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::exists(dir.work / "P.nii.gz"));

  r = run_lamina(dir, "build P.nii.gz -o M.vtu --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::exists(dir.work / "M.vtu"));
  // stdout must be exactly one JSON document (progress and logs go to stderr).
  json built;
  ASSERT_NO_THROW(built = json::parse(r.out)) << r.out;
  EXPECT_EQ(built.at("input"), "P.nii.gz");
  EXPECT_GT(built.at("build_seconds").get<double>(), 0.0);
  const int64_t nodes = built.at("nodes");
  const json& springs = built.at("springs");
  EXPECT_EQ(springs.at("total").get<int64_t>(), springs.at("intra_layer").get<int64_t>() +
                                                    springs.at("inter_layer").get<int64_t>() +
                                                    springs.at("tet_edges").get<int64_t>());
  EXPECT_GT(springs.at("tet_edges").get<int64_t>(), 0) << "nothing fills the layers";
  // The tetrahedra: good ones, none inverted, filling the skin.
  EXPECT_EQ(built.at("structure"), "tets");
  const json& tets = built.at("tets");
  EXPECT_GT(tets.at("count").get<int64_t>(), 0);
  EXPECT_EQ(tets.at("inverted"), 0);
  EXPECT_EQ(tets.at("slivers"), 0);
  EXPECT_GT(tets.at("min_dihedral_deg").get<double>(), 5.0);
  EXPECT_GT(tets.at("mean_dihedral_deg").get<double>(), 60.0);
  const json& layers = built.at("layers");
  ASSERT_EQ(layers.size(), 2u) << "default is two layers";
  int64_t vertices = 0;
  for (size_t k = 0; k < layers.size(); ++k) {
    SCOPED_TRACE("layer " + std::to_string(k));
    const json& l = layers[k];
    EXPECT_EQ(l.at("index"), k);
    for (const char* key : {"vertices", "faces", "closed", "manifold", "components", "volume_ml",
                            "mean_edge_mm", "min_angle_deg"})
      EXPECT_TRUE(l.contains(key)) << key;
    EXPECT_TRUE(l.at("closed").get<bool>());
    EXPECT_TRUE(l.at("manifold").get<bool>());
    EXPECT_EQ(l.at("components"), 1);
    // A closed triangle mesh of genus 0 has F = 2V - 4.
    EXPECT_EQ(l.at("faces").get<int64_t>(), 2 * l.at("vertices").get<int64_t>() - 4);
    EXPECT_GT(l.at("volume_ml").get<double>(), 0.0);
    EXPECT_GT(l.at("mean_edge_mm").get<double>(), 0.0);
    EXPECT_GT(l.at("min_angle_deg").get<double>(), 0.0);
    vertices += l.at("vertices").get<int64_t>();
  }
  EXPECT_EQ(vertices + built.at("interior_nodes").get<int64_t>(), nodes)
      << "every node belongs to exactly one layer or is an interior node";
  EXPECT_NEAR(tets.at("volume_ml").get<double>(), layers[0].at("volume_ml").get<double>(), 1e-6);
  EXPECT_LT(layers[1].at("volume_ml").get<double>(), layers[0].at("volume_ml").get<double>());

  // The saved model reads back as the same model.
  r = run_lamina(dir, "info M.vtu --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json info;
  ASSERT_NO_THROW(info = json::parse(r.out)) << r.out;
  EXPECT_EQ(info.at("nodes"), nodes);
  EXPECT_EQ(info.at("springs").at("total"), springs.at("total"));
  EXPECT_EQ(info.at("springs").at("intra_layer"), springs.at("intra_layer"));
  EXPECT_EQ(info.at("springs").at("inter_layer"), springs.at("inter_layer"));
  EXPECT_EQ(info.at("tets").at("count"), tets.at("count"));
  ASSERT_EQ(info.at("layers").size(), layers.size());
  for (size_t k = 0; k < layers.size(); ++k) {
    EXPECT_EQ(info.at("layers")[k].at("vertices"), layers[k].at("vertices"));
    EXPECT_EQ(info.at("layers")[k].at("faces"), layers[k].at("faces"));
  }

  r = run_lamina(dir, "export M.vtu -o skin.obj");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string obj = read_file(dir.work / "skin.obj");
  EXPECT_EQ(count_obj_lines(obj, "v "), layers[0].at("vertices").get<int64_t>());
  EXPECT_EQ(count_obj_lines(obj, "f "), layers[0].at("faces").get<int64_t>());

  r = run_lamina(dir, "export M.vtu --layer 1 -o inner.stl");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Binary STL: 80-byte header, uint32 triangle count, 50 bytes per triangle.
  const std::string stl = read_file(dir.work / "inner.stl");
  ASSERT_GE(stl.size(), 84u);
  uint32_t triangles = 0;
  std::memcpy(&triangles, stl.data() + 80, 4);
  EXPECT_EQ(triangles, layers[1].at("faces").get<uint32_t>());
  EXPECT_EQ(stl.size(), 84u + 50u * triangles);

  EXPECT_EQ(test::hidden_files(dir.work), std::vector<std::string>{})
      << "temporary files left behind";
}

// Without an input the tool builds the built-in phantom, so a fresh machine needs no data.
TEST(CliWorkflow, BuildWithoutInputUsesThePhantom) {
  TempDir dir;
  const RunResult r = run_lamina(dir, "build -o M.vtu --skin-vertices 300 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir.work / "M.vtu"));
  json built;
  ASSERT_NO_THROW(built = json::parse(r.out)) << r.out;
  EXPECT_NE(test::lowercase(built.at("input").get<std::string>()).find("phantom"),
            std::string::npos);
  EXPECT_GT(built.at("nodes").get<int64_t>(), 300);
  EXPECT_EQ(test::hidden_files(dir.work), std::vector<std::string>{});
}

}  // namespace
}  // namespace lamina
