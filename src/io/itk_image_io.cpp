// ITK lives only here (and in src/geometry/itk_mask_filters.cpp): ITK bundles Eigen 3.3, which
// must not meet the system Eigen 3.4 in one translation unit, and ITK headers compile slowly.
#include <itkGDCMImageIO.h>
#include <itkGDCMImageIOFactory.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>
#include <itkMetaDataObject.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIOFactory.h>
#include <zlib.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>

#include "core/itk_frame.h"
#include "header_checks.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/io/label_volume_io.h"

namespace lamina::io {
namespace {

namespace fs = std::filesystem;
using itk_support::frame_of;
using LabelImage = itk::Image<int32_t, 3>;
using RealImage = itk::Image<double, 3>;

// Explicit registration (rather than CMake's ITK_USE_FILE magic): the formats we read are
// exactly these, and nothing else in the project sees ITK's include paths.
void register_image_formats() {
  static std::once_flag once;
  std::call_once(once, [] {
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::NrrdImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::GDCMImageIOFactory::RegisterOneFactory();
    itk::Object::SetGlobalWarningDisplay(false);  // warnings would bypass our log channel
  });
}

// ITK exception texts span several lines with source locations; keep the description only.
std::string one_line(const itk::ExceptionObject& e) {
  std::string d = e.GetDescription();
  for (char& c : d)
    if (c == '\n' || c == '\r') c = ' ';
  while (!d.empty() && d.back() == ' ') d.pop_back();
  return d.empty() ? std::string("ITK error") : d;
}

// The frame ITK read, whatever the format: the same geometry checks as the raw headers'.
void check_frame(const std::string& path, const GridFrame& f) {
  detail::check_spacing(path, "voxel spacing", f.spacing_mm);
  detail::check_origin(path, "origin", f.origin_mm);
  std::array<std::array<double, 3>, 3> columns{};  // column c: index axis c's direction
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) columns[c][r] = f.direction[3 * r + c];
  detail::check_direction(path, "direction matrix", columns, /*scaled=*/false);
}

// Reads header information and rejects what we cannot use before any voxel is allocated.
void check_header(const std::string& path, itk::ImageIOBase* io, const ReadVolumeOptions& opt) {
  const unsigned dims = io->GetNumberOfDimensions();
  int64_t voxels = 1;
  std::ostringstream shape;
  for (unsigned d = 0; d < dims; ++d) {
    shape << (d ? " x " : "") << io->GetDimensions(d);
    voxels *= static_cast<int64_t>(io->GetDimensions(d));
  }
  bool extra_dims_trivial = true;
  for (unsigned d = 3; d < dims; ++d) extra_dims_trivial &= io->GetDimensions(d) == 1;
  if (dims < 3)
    throw invalid_input(path, "is a " + std::to_string(dims) + "-D image (" + shape.str() +
                                  "); Lamina needs a 3-D segmentation");
  if (!extra_dims_trivial)
    throw invalid_input(path, "is a " + std::to_string(dims) + "-D image (" + shape.str() +
                                  "); Lamina needs a single 3-D segmentation");
  if (io->GetNumberOfComponents() != 1)
    throw invalid_input(path, "has " + std::to_string(io->GetNumberOfComponents()) +
                                  " components per voxel; a label image has one");
  for (unsigned d = 0; d < 3; ++d)
    if (io->GetDimensions(d) == 0)
      throw invalid_input(path, "has a zero dimension (" + shape.str() + ")");
  // Checked here, on the header's own values: ITK's reader later turns a negative spacing into a
  // positive one with a mirrored direction, which would hide a broken header.
  detail::check_spacing(path, "voxel spacing",
                        {io->GetSpacing(0), io->GetSpacing(1), io->GetSpacing(2)});
  if (voxels > opt.max_voxels)
    throw invalid_input(path,
                        "has " + std::to_string(voxels) + " voxels, more than the limit of " +
                            std::to_string(opt.max_voxels) +
                            " (raise it with --max-voxels if the image is really this large)");
}

// MetaIO reports a short read ("data not read completely") on std::cerr and carries on with
// whatever is in the buffer; capture it and make it an error instead of a half-read image.
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(text_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  std::string first_line() const {
    std::string t = text_.str();
    t = t.substr(0, t.find('\n'));
    return t;
  }

 private:
  std::ostringstream text_;
  std::streambuf* old_;
};

template <class Reader>
void run_reader(const std::string& path, Reader* reader) {
  CerrCapture capture;
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw invalid_input(path, "cannot read image data (truncated or corrupt?): " + one_line(e));
  }
  if (!capture.first_line().empty())
    throw invalid_input(path,
                        "cannot read image data (truncated or corrupt?): " + capture.first_line());
}

bool has_metaimage_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".mha" || ext == ".mhd";
}

LabelVolume read_file(const std::string& path, const ReadVolumeOptions& opt) {
  // A format's raw header is checked before ITK reads it (src/io/header_checks.h); MetaImage's
  // before ITK even opens it, as MetaIO can crash on a corrupt one.
  if (has_metaimage_extension(path)) detail::check_metaimage_header(path, opt.max_voxels);
  itk::ImageIOBase::Pointer io = itk::ImageIOFactory::CreateImageIO(
      path.c_str(), itk::ImageIOFactory::IOFileModeEnum::ReadMode);
  if (!io)
    throw invalid_input(path,
                        "not a readable NIfTI (.nii/.nii.gz), NRRD (.nrrd), MetaImage "
                        "(.mha/.mhd) file or DICOM folder");
  const std::string format = io->GetNameOfClass();
  if (format == "NiftiImageIO") detail::check_nifti_header(path, opt.max_voxels);
  if (format == "NrrdImageIO") detail::check_nrrd_header(path, opt.max_voxels);
  if (format == "MetaImageIO" && !has_metaimage_extension(path))
    detail::check_metaimage_header(path, opt.max_voxels);
  try {
    io->SetFileName(path);
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw invalid_input(path, "cannot read the image header: " + one_line(e));
  }
  check_header(path, io, opt);

  LabelVolume out;
  out.source = path;
  const auto ctype = io->GetComponentType();
  const bool is_real =
      ctype == itk::IOComponentEnum::FLOAT || ctype == itk::IOComponentEnum::DOUBLE;
  if (!is_real) {
    auto reader = itk::ImageFileReader<LabelImage>::New();
    reader->SetImageIO(io);
    reader->SetFileName(path);
    run_reader(path, reader.GetPointer());
    LabelImage* image = reader->GetOutput();
    out.frame = frame_of(image);
    const int32_t* p = image->GetBufferPointer();
    out.labels.assign(p, p + out.frame.voxel_count());
  } else {
    // Floating-point masks (common from Python pipelines) hold 0.0/1.0: round to labels.
    auto reader = itk::ImageFileReader<RealImage>::New();
    reader->SetImageIO(io);
    reader->SetFileName(path);
    run_reader(path, reader.GetPointer());
    RealImage* image = reader->GetOutput();
    out.frame = frame_of(image);
    const double* p = image->GetBufferPointer();
    out.labels.resize(static_cast<size_t>(out.frame.voxel_count()));
    for (size_t n = 0; n < out.labels.size(); ++n) {
      if (!std::isfinite(p[n]))
        throw invalid_input(
            path, "holds a non-finite voxel value (NaN or infinity) at voxel " + std::to_string(n));
      if (std::abs(p[n]) > 2.0e9)
        throw invalid_input(path, "holds a voxel value too large for a label");
      out.labels[n] = static_cast<int32_t>(std::lround(p[n]));
    }
  }
  return out;
}

LabelVolume read_dicom_folder(const std::string& path, const ReadVolumeOptions& opt) {
  auto names = itk::GDCMSeriesFileNames::New();
  std::vector<std::string> files;
  // GDCM reports what it cannot sort (a slice without a position) on std::cerr; the slices'
  // tags are checked below and refused in one line instead.
  CerrCapture gdcm_chatter;
  try {
    names->SetUseSeriesDetails(true);
    names->SetDirectory(path);
    const auto& uids = names->GetSeriesUIDs();
    if (uids.empty())
      throw invalid_input(path,
                          "is a folder but holds no DICOM series (give a .nii.gz, .nrrd, "
                          ".mha file, or a folder of DICOM slices)");
    // Several series in one folder: take the one with the most slices.
    for (const auto& uid : uids) {
      auto f = names->GetFileNames(uid);
      if (f.size() > files.size()) files = f;
    }
  } catch (const itk::ExceptionObject& e) {
    throw invalid_input(path, "cannot scan the DICOM folder: " + one_line(e));
  }
  auto dicom = itk::GDCMImageIO::New();
  auto reader = itk::ImageSeriesReader<LabelImage>::New();
  reader->SetImageIO(dicom);
  reader->SetFileNames(files);
  try {
    reader->UpdateOutputInformation();
  } catch (const itk::ExceptionObject& e) {
    throw invalid_input(path, "cannot read the DICOM series: " + one_line(e));
  }
  const auto size = reader->GetOutput()->GetLargestPossibleRegion().GetSize();
  if (size[2] < 2)
    throw invalid_input(path,
                        "holds a single DICOM slice (a 2-D image); Lamina needs a 3-D series");
  if (static_cast<int64_t>(size[0] * size[1] * size[2]) > opt.max_voxels)
    throw invalid_input(path, "DICOM series is larger than the voxel limit");
  run_reader(path, reader.GetPointer());
  // Each slice's own geometry, from the tags the reader kept (a tag it did not find is absent
  // from the slice's dictionary, where GDCM's own reading would have put a default).
  std::vector<detail::DicomSliceTags> tags(files.size());
  const auto* dictionaries = reader->GetMetaDataDictionaryArray();
  for (size_t k = 0; k < files.size() && dictionaries && k < dictionaries->size(); ++k) {
    const itk::MetaDataDictionary& d = *(*dictionaries)[k];
    tags[k].file = files[k];
    itk::ExposeMetaData<std::string>(d, "0020|0032", tags[k].position);
    itk::ExposeMetaData<std::string>(d, "0020|0037", tags[k].orientation);
    itk::ExposeMetaData<std::string>(d, "0028|0030", tags[k].pixel_spacing);
  }
  const detail::DicomGrid grid = detail::check_dicom_slices(path, tags);
  LabelVolume out;
  out.source = path;
  out.frame = frame_of(reader->GetOutput());
  detail::check_dicom_grid(path, grid, out.frame.spacing_mm, out.frame.origin_mm,
                           out.frame.direction);
  const int32_t* p = reader->GetOutput()->GetBufferPointer();
  out.labels.assign(p, p + out.frame.voxel_count());
  return out;
}

template <class Pixel>
void write_as(const LabelVolume& v, const std::string& tmp) {
  using Image = itk::Image<Pixel, 3>;
  auto image = Image::New();
  image->SetRegions(itk_support::apply_frame(image.GetPointer(), v.frame));
  image->Allocate();
  Pixel* p = image->GetBufferPointer();
  for (size_t n = 0; n < v.labels.size(); ++n) p[n] = static_cast<Pixel>(v.labels[n]);
  auto writer = itk::ImageFileWriter<Image>::New();
  writer->SetFileName(tmp);
  writer->SetInput(image);
  writer->SetUseCompression(true);
  writer->Update();
}

}  // namespace

LabelVolume read_label_volume(const std::string& path, const ReadVolumeOptions& options) {
  register_image_formats();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw invalid_input(path, "no such file or folder");
  LabelVolume v =
      fs::is_directory(path, ec) ? read_dicom_folder(path, options) : read_file(path, options);
  check_frame(path, v.frame);
  return v;
}

void write_label_volume(const LabelVolume& volume, const std::string& path) {
  register_image_formats();
  if (static_cast<int64_t>(volume.labels.size()) != volume.frame.voxel_count())
    throw Error(ErrorKind::kInternal, path + ": label count does not match the grid size");
  // Write into a temporary folder under the final file name(s), then move them into place: a
  // MetaImage .mhd header names its data file, so the names must already be the final ones.
  const std::string tmp_dir = temporary_path_beside(path);
  std::error_code ec;
  if (!fs::create_directory(tmp_dir, ec))
    throw Error(ErrorKind::kOutput, path + ": cannot write: " + ec.message());
  const fs::path target(path);
  int32_t lo = 0, hi = 0;
  for (int32_t l : volume.labels) lo = std::min(lo, l), hi = std::max(hi, l);
  try {
    const std::string tmp = (fs::path(tmp_dir) / target.filename()).string();
    if (lo >= 0 && hi <= 255)
      write_as<uint8_t>(volume, tmp);
    else
      write_as<int32_t>(volume, tmp);
    // The main file last, so that a reader never finds a header without its data.
    for (const auto& entry : fs::directory_iterator(tmp_dir))
      if (entry.path().filename() != target.filename())
        commit_temporary(entry.path().string(),
                         (target.parent_path() / entry.path().filename()).string());
    commit_temporary(tmp, path);
  } catch (const itk::ExceptionObject& e) {
    fs::remove_all(tmp_dir, ec);
    throw Error(ErrorKind::kOutput, path + ": cannot write image: " + one_line(e));
  } catch (...) {
    fs::remove_all(tmp_dir, ec);
    throw;
  }
  fs::remove_all(tmp_dir, ec);
}

}  // namespace lamina::io
