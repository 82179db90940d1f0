// Reading a folder holding one DICOM series. The series is written here with ITK itself, so this
// translation unit sees ITK's headers (tests/CMakeLists.txt) and, like src/io/itk_image_io.cpp,
// must include no Eigen and no lamina header that includes Eigen.
#include <gdcmReader.h>
#include <gdcmWriter.h>
#include <gtest/gtest.h>
#include <itkGDCMImageIO.h>
#include <itkImage.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>
#include <itkNumericSeriesFileNames.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/core/grid.h"
#include "lamina/io/label_volume_io.h"
#include "support/refusal.h"
#include "support/run_cli.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina::io {
namespace {

using lamina::test::TempDir;

namespace fs = std::filesystem;

using Volume = itk::Image<uint16_t, 3>;
using Slice = itk::Image<uint16_t, 2>;

// Labels 0..29 that encode the voxel's position, so a reader that sorted the slices wrongly or
// swapped axes returns other labels.
uint16_t label_at(int64_t i, int64_t j, int64_t k) {
  return static_cast<uint16_t>((i % 3) + 3 * (j % 2) + 6 * (k % 5));
}

// Writes a label volume as one DICOM series into `dir`, one file per slice along k, with the
// per-slice geometry and identity tags a scanner would write (as ITK's example
// Examples/IO/ImageReadDicomSeriesWrite.cxx does). Identity direction. With
// `reverse_file_names`, the first file holds the last slice, as some exporters name them.
// `position_of(k, ipp)` may move slice k's Image Position (Patient), x\\y\\z; with
// `secondary_capture`, the SOP class carries no geometry tags at all.
using PositionEdit = std::function<void(int64_t k, std::array<double, 3>& position)>;
void write_series(const fs::path& dir, const std::array<int64_t, 3>& size,
                  const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                  bool reverse_file_names = false, const PositionEdit& position_of = {},
                  bool secondary_capture = false) {
  auto image = Volume::New();
  Volume::RegionType region;
  Volume::SpacingType sp;
  Volume::PointType org;
  for (unsigned a = 0; a < 3; ++a) {
    region.SetSize(a, static_cast<itk::SizeValueType>(size[a]));
    sp[a] = spacing[a];
    org[a] = origin[a];
  }
  image->SetRegions(region);
  image->SetSpacing(sp);
  image->SetOrigin(org);
  image->Allocate();
  for (int64_t k = 0; k < size[2]; ++k)
    for (int64_t j = 0; j < size[1]; ++j)
      for (int64_t i = 0; i < size[0]; ++i) image->SetPixel({{i, j, k}}, label_at(i, j, k));

  // Fixed UIDs (any digits-and-dots string is valid); all slices share study and series.
  const std::string study = "1.2.826.0.1.3680043.2.1125.20261121.1";
  const std::string series = "1.2.826.0.1.3680043.2.1125.20261121.2";
  const std::string frame_of_reference = "1.2.826.0.1.3680043.2.1125.20261121.3";
  std::vector<itk::MetaDataDictionary> dicts(static_cast<size_t>(size[2]));
  std::vector<itk::MetaDataDictionary*> dict_ptrs;
  for (int64_t k = 0; k < size[2]; ++k) {
    itk::MetaDataDictionary& d = dicts[static_cast<size_t>(k)];
    const auto set = [&d](const std::string& tag, const std::string& value) {
      itk::EncapsulateMetaData<std::string>(d, tag, value);
    };
    std::ostringstream position, pixel_spacing, thickness, number, sop;
    position.precision(17);
    pixel_spacing.precision(17);
    thickness.precision(17);
    std::array<double, 3> at{origin[0], origin[1], origin[2] + spacing[2] * k};
    if (position_of) position_of(k, at);
    position << at[0] << "\\" << at[1] << "\\" << at[2];
    pixel_spacing << spacing[1] << "\\" << spacing[0];  // row spacing (along j) first
    thickness << spacing[2];
    number << k + 1;
    sop << series << "." << k + 1;
    set("0008|0060", "OT");                  // Modality
    set("0008|0008", "DERIVED\\SECONDARY");  // Image Type
    // SOP Class UID: CT Image Storage. Without it GDCM writes Secondary Capture, which has no
    // Image Position/Orientation (the series then reads back at origin 0 with 1 mm slices).
    if (!secondary_capture) set("0008|0016", "1.2.840.10008.5.1.4.1.1.2");
    // Photometric Interpretation; without it GDCM warns on stderr for every slice.
    set("0028|0004", "MONOCHROME2");
    set("0020|000d", study);                // Study Instance UID
    set("0020|000e", series);               // Series Instance UID
    set("0020|0052", frame_of_reference);   // Frame of Reference UID
    set("0008|0018", sop.str());            // SOP Instance UID
    set("0020|0013", number.str());         // Instance Number
    set("0020|0032", position.str());       // Image Position (Patient)
    set("0020|0037", "1\\0\\0\\0\\1\\0");   // Image Orientation (Patient)
    set("0028|0030", pixel_spacing.str());  // Pixel Spacing
    set("0018|0050", thickness.str());      // Slice Thickness
    set("0018|0088", thickness.str());      // Spacing Between Slices
    dict_ptrs.push_back(&d);
  }

  auto names = itk::NumericSeriesFileNames::New();
  names->SetSeriesFormat((dir / "slice%03d.dcm").string());
  names->SetStartIndex(1);
  names->SetEndIndex(static_cast<itk::SizeValueType>(size[2]));
  names->SetIncrementIndex(1);

  // An explicit GDCMImageIO, so no IO factory needs registering here.
  auto dicom = itk::GDCMImageIO::New();
  dicom->KeepOriginalUIDOn();  // use the UIDs above rather than fresh ones per file
  auto writer = itk::ImageSeriesWriter<Volume, Slice>::New();
  writer->SetInput(image);
  writer->SetImageIO(dicom);
  std::vector<std::string> files = names->GetFileNames();
  if (reverse_file_names) std::reverse(files.begin(), files.end());
  writer->SetFileNames(files);
  writer->SetMetaDataDictionaryArray(&dict_ptrs);
  writer->Update();
}

class DicomSeries : public ::testing::TestWithParam<bool> {};

// Slices are ordered by their position in space, not by file name.
TEST_P(DicomSeries, FolderReadsAsOneVolume) {
  TempDir dir;
  const std::array<int64_t, 3> size{9, 7, 6};
  const std::array<double, 3> spacing{0.75, 0.75, 2.5}, origin{-40.0, 12.5, 100.0};
  ASSERT_NO_THROW(write_series(dir.path, size, spacing, origin, GetParam()));

  const LabelVolume v = read_label_volume(dir.path.string());
  EXPECT_EQ(v.frame.size, size);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(v.frame.spacing_mm[a], spacing[a], 1e-3) << "spacing " << a;
    EXPECT_NEAR(v.frame.origin_mm[a], origin[a], 1e-3) << "origin " << a;
  }
  const std::array<double, 9> identity{1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(v.frame.direction[n], identity[n], 1e-6) << n;
  ASSERT_EQ(static_cast<int64_t>(v.labels.size()), v.frame.voxel_count());
  int64_t wrong = 0;
  for (int64_t k = 0; k < size[2]; ++k)
    for (int64_t j = 0; j < size[1]; ++j)
      for (int64_t i = 0; i < size[0]; ++i)
        wrong += v.labels[v.frame.index(i, j, k)] != label_at(i, j, k);
  EXPECT_EQ(wrong, 0) << "voxels whose label differs from the written one";
}

INSTANTIATE_TEST_SUITE_P(FileNames, DicomSeries, ::testing::Bool(), [](const auto& info) {
  return std::string(info.param ? "ReversedFileNames" : "FileNamesInSliceOrder");
});

// A single slice is a 2-D image, which Lamina cannot model.
TEST(DicomSingleSlice, IsRejectedAsTwoDimensional) {
  TempDir dir;
  ASSERT_NO_THROW(write_series(dir.path, {9, 7, 1}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}));
  try {
    read_label_volume(dir.path.string());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_NE(std::string(e.what()).find("2-D"), std::string::npos) << e.what();
  }
}

// ----- Series whose slices do not make one grid: `lamina build` refuses each by name, with the
// slice and the tag, exit code 2 and no output (docs/errors.md, "Volume headers"). ITK's series
// reader would stack them at the first two slices' spacing without a word.

// Removes tag (group, element) from one written slice, as an exporter that lost it would.
void remove_tag(const fs::path& file, uint16_t group, uint16_t element) {
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  ASSERT_TRUE(reader.Read()) << file;
  reader.GetFile().GetDataSet().Remove(gdcm::Tag(group, element));
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  writer.SetFileName(file.string().c_str());
  ASSERT_TRUE(writer.Write()) << file;
}

struct SeriesCase {
  std::string name;
  std::function<void(const fs::path& dir)> write;
  std::vector<std::string> message_has;
};

std::vector<SeriesCase> series_cases() {
  const std::array<int64_t, 3> size{8, 8, 6};
  const std::array<double, 3> spacing{1.0, 1.0, 2.5}, origin{0.0, 0.0, 0.0};
  std::vector<SeriesCase> c;
  // GDCM writes the positions but reads a Secondary Capture series at 1 mm slices from 0.
  c.push_back({"SecondaryCaptureReadWithoutItsGeometry",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin, false, {}, /*secondary_capture=*/true);
               },
               {"tags say", "x 2.5 mm", "Secondary Capture"}});
  c.push_back({"OneSliceWithoutPosition",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin);
                 remove_tag(d / "slice004.dcm", 0x0020, 0x0032);
               },
               {"slice004.dcm", "Image Position (Patient)"}});
  c.push_back({"MissingSlice",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin, false, [](int64_t k, auto& p) {
                   if (k >= 3) p[2] += 2.5;  // the slice at 7.5 mm is not there
                 });
               },
               {"uneven slice positions", "5.000 mm", "2.500 mm"}});
  c.push_back({"TwoSlicesAtOnePosition",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin, false, [](int64_t k, auto& p) {
                   if (k == 2) p[2] = 2.5;  // the same place as slice 2
                 });
               },
               {"same position"}});
  c.push_back({"TiltedGantry",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin, false,
                              [](int64_t k, auto& p) { p[1] += 0.8 * static_cast<double>(k); });
               },
               {"shifted in their own plane", "tilted gantry"}});
  c.push_back({"OneSliceWithoutPixelSpacing",
               [=](const fs::path& d) {
                 write_series(d, size, spacing, origin);
                 remove_tag(d / "slice002.dcm", 0x0028, 0x0030);
               },
               {"slice002.dcm", "Pixel Spacing"}});
  return c;
}

void PrintTo(const SeriesCase& c, std::ostream* os) {
  *os << c.name;
}

class BadSeries : public ::testing::TestWithParam<SeriesCase> {};

TEST_P(BadSeries, IsRefusedByNameWithExitTwoAndNoOutput) {
  TempDir dir;
  const fs::path work = dir.path / "work", scans = work / "scans";
  fs::create_directories(scans);
  ASSERT_NO_FATAL_FAILURE(GetParam().write(scans));
  const std::string args =
      "build " + test::quoted(scans.string()) + " -o " + test::quoted((work / "OUT.vtu").string());
  const test::RunResult r = test::run_cli(test::lamina_cli(), work, dir.path, args);
  std::vector<std::string> words = GetParam().message_has;
  words.push_back("scans");
  const auto problems = test::refusal_problems(r, words, {"OUT.vtu"}, work);
  EXPECT_TRUE(problems.empty()) << "lamina " << args << "\n"
                                << test::as_list(problems) << "stderr was:\n"
                                << r.err;
}

INSTANTIATE_TEST_SUITE_P(Cli, BadSeries, ::testing::ValuesIn(series_cases()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace lamina::io
