// Volume headers a reader library would repair without a word (docs/errors.md, "Volume
// headers"): each case writes a small mask whose header has one bad field, runs `lamina build`
// on it, and requires exit code 2, one line naming the file, the field and the problem, and no
// output file. The DICOM cases are in tests/io/dicom_series_test.cpp, which can write a series.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/io/label_volume_io.h"
#include "support/refusal.h"
#include "support/run_cli.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::RunResult;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Dir : test::TempDir {
  fs::path work = path / "work";
  Dir() { fs::create_directories(work); }
  std::string file(const std::string& name) const { return (work / name).string(); }
};

std::string read_bytes(const fs::path& p) {
  return test::read_text(p);
}

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

// A 10^3 mask at 2 mm with a cube of ones inside: valid under any sound header.
LabelVolume small_cube() {
  LabelVolume v;
  v.frame.size = {10, 10, 10};
  v.frame.spacing_mm = {2.0, 2.0, 2.0};
  v.labels.assign(1000, 0);
  for (int64_t k = 2; k < 8; ++k)
    for (int64_t j = 2; j < 8; ++j)
      for (int64_t i = 2; i < 8; ++i) v.labels[v.frame.index(i, j, k)] = 1;
  return v;
}

std::string cube_voxels() {
  const LabelVolume v = small_cube();
  std::string bytes(v.labels.size(), '\0');
  for (size_t n = 0; n < v.labels.size(); ++n) bytes[n] = static_cast<char>(v.labels[n]);
  return bytes;
}

// ----- NIfTI: a sound file written by Lamina (ITK), then one field overwritten in place.
// Byte offsets from nifti1.h.
enum Field : int {
  kDatatype = 70,
  kBitpix = 72,
  kPixdim = 76,
  kVoxOffset = 108,
  kSclSlope = 112,
  kSclInter = 116,
  kQformCode = 252,
  kSformCode = 254,
  kQuatern = 256,
  kQoffset = 268,
  kSrowX = 280,
  kSrowY = 296,
};

struct Patch {
  int at;
  double value;
  bool is_short = false;
};

// Writes small_cube() as `name` (.nii or .nii.gz) with `patches` applied to its header.
void write_nifti(const Dir& d, const std::string& name, const std::vector<Patch>& patches) {
  const fs::path plain = d.work / "sound.nii";
  io::write_label_volume(small_cube(), plain.string());
  std::string bytes = read_bytes(plain);
  fs::remove(plain);
  for (const Patch& p : patches) {
    if (p.is_short) {
      const int16_t v = static_cast<int16_t>(p.value);
      std::memcpy(&bytes[p.at], &v, 2);
    } else {
      const float v = static_cast<float>(p.value);
      std::memcpy(&bytes[p.at], &v, 4);
    }
  }
  if (name.ends_with(".gz")) {
    gzFile f = gzopen(d.file(name).c_str(), "wb");
    gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size()));
    gzclose(f);
  } else {
    write_bytes(d.work / name, bytes);
  }
}

// ----- NRRD and MetaImage: text headers written out in full.
std::string nrrd(const std::string& geometry, const std::string& voxels = cube_voxels()) {
  return "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\nspace: left-posterior-superior\n" +
         geometry + "encoding: raw\n\n" + voxels;
}
const std::string kSoundDirections = "space directions: (2,0,0) (0,2,0) (0,0,2)\n";
const std::string kSoundOrigin = "space origin: (0,0,0)\n";

std::string mha(const std::string& geometry, const std::string& voxels = cube_voxels()) {
  return "ObjectType = Image\nNDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\n" + geometry +
         "ElementDataFile = LOCAL\n" + voxels;
}

struct HeaderCase {
  std::string name;
  std::function<std::string(const Dir&)> write;  // writes the input, returns its file name
  std::vector<std::string> message_has;          // besides the file name
};

std::vector<HeaderCase> header_cases() {
  std::vector<HeaderCase> c;
  const auto nifti = [&](const std::string& name, std::vector<Patch> patches,
                         std::vector<std::string> words, const std::string& ext = ".nii") {
    c.push_back({"Nifti" + name,
                 [=](const Dir& d) {
                   write_nifti(d, "mask" + ext, patches);
                   return std::string("mask") + ext;
                 },
                 words});
  };
  // The issue's own case: pixdim 0 read as a 1 mm grid.
  nifti("PixdimZeroGzipped", {{kPixdim + 8, 0.0}}, {"pixdim", "0"}, ".nii.gz");
  nifti("PixdimNaN", {{kPixdim + 4, kNaN}}, {"pixdim", "nan"});
  nifti("PixdimNegative", {{kPixdim + 12, -2.0}}, {"pixdim", "-2"});
  nifti("PixdimInfinite", {{kPixdim + 4, kInf}}, {"pixdim", "inf"});
  nifti("SformSheared", {{kSrowX + 4, 1.0}}, {"sform", "orthogonal"});
  nifti("SformSingular", {{kSrowX + 4, -2.0}, {kSrowY + 4, 0.0}}, {"sform", "singular"});
  nifti("SformNaN", {{kSrowX, kNaN}}, {"sform", "not finite"});
  nifti("SformVoxelSizeDisagreesWithPixdim", {{kSrowX, -4.0}}, {"sform", "pixdim"});
  nifti("QformQuaternionTooLong", {{kSformCode, 0, true}, {kQuatern, 0.9}, {kQuatern + 4, 0.9}},
        {"quaternion", "longer than 1"});
  nifti("QformOriginInfinite", {{kSformCode, 0, true}, {kQoffset + 4, kInf}},
        {"qoffset", "finite"});
  nifti("QformAndSformDisagree", {{kQoffset, 50.0}}, {"qform", "sform", "different"});
  nifti("TransformCodeUnknown", {{kQformCode, 9, true}}, {"qform_code", "9"});
  nifti("ScaledLabels", {{kSclSlope, 2.0}}, {"scl_slope", "2"});
  nifti("ScalingNaN", {{kSclSlope, kNaN}}, {"scl_slope", "not finite"});
  nifti("VoxOffsetInsideTheHeader", {{kVoxOffset, 100.0}}, {"vox_offset", "100"});
  nifti("BitpixDisagreesWithDatatype", {{kBitpix, 16, true}}, {"bitpix", "datatype"});
  nifti("DataShorterThanTheHeaderSays", {{kVoxOffset, 1024.0}}, {"truncated"});

  const auto text = [&](const std::string& name, const std::string& file,
                        std::function<std::string()> content, std::vector<std::string> words) {
    c.push_back({name,
                 [=](const Dir& d) {
                   write_bytes(d.work / file, content());
                   return file;
                 },
                 words});
  };
  text("NrrdDirectionZero", "mask.nrrd",
       [] { return nrrd("space directions: (2,0,0) (0,0,0) (0,0,2)\n" + kSoundOrigin); },
       {"space directions", "no length"});
  text("NrrdDirectionNaN", "mask.nrrd",
       [] { return nrrd("space directions: (2,0,0) (0,nan,0) (0,0,2)\n" + kSoundOrigin); },
       {"space directions", "not finite"});
  text("NrrdDirectionsSingular", "mask.nrrd",
       [] { return nrrd("space directions: (2,0,0) (2,0,0) (0,0,2)\n" + kSoundOrigin); },
       {"space directions", "singular"});
  text("NrrdDirectionsSheared", "mask.nrrd",
       [] { return nrrd("space directions: (2,0,0) (1,2,0) (0,0,2)\n" + kSoundOrigin); },
       {"space directions", "orthogonal"});
  text("NrrdOriginNaN", "mask.nrrd",
       [] { return nrrd(kSoundDirections + "space origin: (0,nan,0)\n"); },
       {"space origin", "not finite"});
  text("NrrdNoSpacing", "mask.nrrd", [] { return nrrd(kSoundOrigin); }, {"no voxel size", "1 mm"});
  text("NrrdSpacingsZero", "mask.nrrd", [] { return nrrd("spacings: 2 0 2\n"); },
       {"spacings", "0"});
  text("NrrdSpaceUnitsMetres", "mask.nrrd",
       [] { return nrrd(kSoundDirections + kSoundOrigin + "space units: \"m\" \"m\" \"m\"\n"); },
       {"space units", "millimetres"});
  text("NrrdRawDataShort", "mask.nrrd",
       [] { return nrrd(kSoundDirections + kSoundOrigin, cube_voxels().substr(0, 600)); },
       {"truncated", "1000", "600"});
  text("MetaImageSpacingNaN", "mask.mha", [] { return mha("ElementSpacing = 2 nan 2\n"); },
       {"ElementSpacing", "nan"});
  text("MetaImageSpacingInfinite", "mask.mha", [] { return mha("ElementSpacing = 2 2 inf\n"); },
       {"ElementSpacing", "inf"});
  text("MetaImageNoSpacing", "mask.mha", [] { return mha("Offset = 0 0 0\n"); },
       {"ElementSpacing", "1 mm"});
  text("MetaImageMatrixSingular", "mask.mha",
       [] { return mha("ElementSpacing = 2 2 2\nTransformMatrix = 1 0 0 1 0 0 0 0 1\n"); },
       {"TransformMatrix", "singular"});
  text("MetaImageMatrixNotARotation", "mask.mha",
       [] { return mha("ElementSpacing = 2 2 2\nTransformMatrix = 1 0 0 0.5 0.866 0 0 0 1\n"); },
       {"TransformMatrix", "orthogonal"});
  text("MetaImageMatrixNaN", "mask.mha",
       [] { return mha("ElementSpacing = 2 2 2\nTransformMatrix = 1 0 0 0 nan 0 0 0 1\n"); },
       {"TransformMatrix", "not finite"});
  text("MetaImageOffsetInfinite", "mask.mha",
       [] { return mha("ElementSpacing = 2 2 2\nOffset = 0 -inf 0\n"); }, {"Offset", "not finite"});
  // Compressed MetaImage as Lamina (ITK) writes it, its CompressedDataSize line replaced: a
  // wrong size made MetaIO hang in inflate, allocate without bound or fill the rest with zeros.
  const auto compressed = [&](const std::string& name, const std::string& size_line,
                              std::vector<std::string> words) {
    c.push_back({name,
                 [=](const Dir& d) {
                   io::write_label_volume(small_cube(), d.file("mask.mha"));
                   std::string bytes = read_bytes(d.work / "mask.mha");
                   const size_t at = bytes.find("CompressedDataSize = ");
                   bytes.replace(at, bytes.find('\n', at) - at, size_line);
                   write_bytes(d.work / "mask.mha", bytes);
                   return std::string("mask.mha");
                 },
                 words});
  };
  compressed("MetaImageCompressedDataSizeTooSmall", "CompressedDataSize = 10",
             {"CompressedDataSize", "10 bytes"});
  compressed("MetaImageCompressedDataSizeNegative", "CompressedDataSize = -5",
             {"CompressedDataSize", "-5"});
  compressed("MetaImageEmptyValue", "CompressedDataSize = ", {"CompressedDataSize", "no value"});
  compressed("MetaImageRepeatedKey", "NDims = 3", {"NDims", "second time"});
  return c;
}

void PrintTo(const HeaderCase& c, std::ostream* os) {
  *os << c.name;
}

class BadHeader : public ::testing::TestWithParam<HeaderCase> {};

TEST_P(BadHeader, IsRefusedByNameWithExitTwoAndNoOutput) {
  const HeaderCase& bad = GetParam();
  Dir dir;
  const std::string input = bad.write(dir);
  const std::string args =
      "build " + quoted(dir.file(input)) + " -o " + quoted(dir.file("OUT.vtu"));
  const RunResult r = test::run_cli(test::lamina_cli(), dir.work, dir.path, args);
  std::vector<std::string> words = bad.message_has;
  words.push_back(input);
  const auto problems = test::refusal_problems(r, words, {"OUT.vtu"}, dir.work);
  EXPECT_TRUE(problems.empty()) << "lamina " << args << "\n"
                                << test::as_list(problems) << "stderr was:\n"
                                << r.err;
}

INSTANTIATE_TEST_SUITE_P(Cli, BadHeader, ::testing::ValuesIn(header_cases()),
                         [](const auto& info) { return info.param.name; });

// The writers of the cases above, with sound values, give files that build: each case fails for
// its one bad field, not for the way it was written.
TEST(SoundHeader, EachFormatAsTheCasesWriteItBuilds) {
  Dir dir;
  write_nifti(dir, "sound.nii.gz", {});
  write_bytes(dir.work / "sound.nrrd", nrrd(kSoundDirections + kSoundOrigin));
  write_bytes(dir.work / "sound.mha", mha("ElementSpacing = 2 2 2\nOffset = 0 0 0\n"
                                          "TransformMatrix = 1 0 0 0 1 0 0 0 1\n"));
  for (const std::string name : {"sound.nii.gz", "sound.nrrd", "sound.mha"}) {
    SCOPED_TRACE(name);
    const RunResult r =
        test::run_cli(test::lamina_cli(), dir.work, dir.path,
                      "-q build " + quoted(dir.file(name)) + " -o " + quoted(dir.file("ok.vtu")) +
                          " --skin-vertices 200 --layers 1");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir.work / "ok.vtu"));
    fs::remove(dir.work / "ok.vtu");
  }
}

}  // namespace
}  // namespace lamina
