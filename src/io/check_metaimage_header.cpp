// The raw MetaImage header (src/io/header_checks.h). ITK 5.2's MetaIO trusts it and kills the
// process on some corrupt ones, which fuzz_volume found (docs/testing.md): a "Key = Value" key
// longer than its 255-byte buffer aborts in strcpy, a slice-file pattern ElementDataFile
// ("name%03d.raw MIN MAX STEP") with a step of 0 divides by zero (SIGFPE), and a negative NDims
// hangs it. It also repairs silently: no ElementSpacing reads as 1 mm. So the header is checked
// here first: printable lines of "Key = Value" with a short alphanumeric key, positive NDims and
// DimSize, a present, finite, positive spacing, a rotation for TransformMatrix, a finite Offset,
// and an ElementDataFile line naming LOCAL or one data file that holds what the header
// describes. Every MetaImage that ITK, 3D Slicer or Lamina writes passes.
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "header_checks.h"
#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

namespace fs = std::filesystem;

int element_bytes(const std::string& type) {
  static const std::map<std::string, int> sizes = {
      {"MET_CHAR", 1},  {"MET_UCHAR", 1}, {"MET_SHORT", 2},     {"MET_USHORT", 2},
      {"MET_INT", 4},   {"MET_UINT", 4},  {"MET_LONG_LONG", 8}, {"MET_ULONG_LONG", 8},
      {"MET_FLOAT", 4}, {"MET_DOUBLE", 8}};
  const auto it = sizes.find(type);
  return it == sizes.end() ? 0 : it->second;
}

std::vector<double> numbers(const std::string& value) {
  std::vector<double> out;
  std::istringstream in(value);
  for (std::string t; in >> t;) {
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    out.push_back(*end == '\0' ? v : std::nan(""));
  }
  return out;
}

}  // namespace

void check_metaimage_header(const std::string& path, int64_t max_voxels) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return;  // ITK reports a missing or unreadable file in its own words
  const auto bad = [&](int line, const std::string& problem) {
    return invalid_input(path, "MetaImage header line " + std::to_string(line) + ": " + problem);
  };
  std::map<std::string, std::pair<std::string, int>> field;  // key -> value, line
  std::string line;
  for (int n = 1; n <= 200 && std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    for (const char c : line)
      if (!(c == '\t' || (c >= 32 && c < 127)))
        throw bad(n, "holds a byte that is not text (a corrupt header?)");
    const size_t eq = line.find('=');
    if (eq == std::string::npos) throw bad(n, "expected 'Key = Value'");
    std::string key = line.substr(0, eq);
    key.erase(key.find_last_not_of(" \t") + 1);
    key.erase(0, key.find_first_not_of(" \t"));
    if (key.empty() || key.size() > 64 ||
        key.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_") !=
            std::string::npos)
      throw bad(n, "'" + key.substr(0, 40) + "' is not a MetaImage key");
    std::string value = line.substr(eq + 1);
    value.erase(0, value.find_first_not_of(" \t"));
    value.erase(value.find_last_not_of(" \t") + 1);
    // MetaIO misreads the rest of a header after an empty value ("DimSize required and not
    // defined" on stderr) and takes the last of repeated keys: neither occurs in a header any
    // writer makes (fuzz_volume).
    if (value.empty()) throw bad(n, "'" + key + "' has no value");
    if (field.count(key)) throw bad(n, "'" + key + "' appears a second time");
    field[key] = {value, n};
    // A CompressedDataSize that is not the compressed data's size makes MetaIO hang in inflate,
    // allocate without bound (negative) or inflate part of the data and leave the rest zero
    // (fuzz_volume): a positive whole number, checked against the data below.
    if (key == "CompressedDataSize" &&
        (value.find_first_not_of("0123456789") != std::string::npos || value.size() > 15 ||
         std::stoll(value) < 1))
      throw bad(n, "CompressedDataSize must be a positive whole number of bytes, got '" +
                       value.substr(0, 40) + "'");
    // MetaIO loops without end on a negative NDims or DimSize (fuzz_volume): sizes must be
    // positive integers.
    if (key == "NDims" || key == "DimSize") {
      std::istringstream values(value);
      int count = 0;
      for (std::string token; values >> token; ++count)
        if (token.find_first_not_of("0123456789") != std::string::npos || token.size() > 9 ||
            std::stol(token) < 1)
          throw bad(n, key + " must be positive whole numbers, got '" + value.substr(0, 40) + "'");
      if (count == 0) throw bad(n, key + " has no value");
      continue;
    }
    if (key != "ElementDataFile") continue;
    if (value.find('%') != std::string::npos || value.rfind("LIST", 0) == 0)
      throw bad(n,
                "ElementDataFile is a multi-file pattern or LIST, which Lamina does not read: "
                "save the mask as one .mha, .nii.gz or .nrrd file");
    break;  // the voxel data follows
  }
  if (!field.count("ElementDataFile"))
    throw invalid_input(path,
                        "MetaImage header has no ElementDataFile line in its first 200 lines");
  const std::streamoff data_start = in.tellg();
  const auto value = [&](const char* key) -> std::string {
    const auto it = field.find(key);
    return it == field.end() ? std::string() : it->second.first;
  };
  const auto first_of = [&](std::initializer_list<const char*> keys) -> std::string {
    for (const char* k : keys)
      if (field.count(k)) return k;
    return {};
  };

  // Geometry: only for 3-D images (ITK's own checks name the other shapes).
  const std::vector<double> dims = numbers(value("NDims"));
  const std::vector<double> size = numbers(value("DimSize"));
  if (dims.size() != 1 || dims[0] != 3.0 || size.size() != 3) return;
  const std::string spacing_key = first_of({"ElementSpacing", "ElementSize"});
  if (spacing_key.empty())
    throw invalid_input(path,
                        "MetaImage header gives no voxel size (ElementSpacing), and a "
                        "reader would assume 1 mm: add it");
  const std::vector<double> s = numbers(value(spacing_key.c_str()));
  if (s.size() != 3)
    throw invalid_input(
        path, fmt::format("MetaImage {} has {} values for a 3-D image", spacing_key, s.size()));
  check_spacing(path, "MetaImage " + spacing_key, {s[0], s[1], s[2]});
  const std::string matrix_key = first_of({"TransformMatrix", "Rotation", "Orientation"});
  if (!matrix_key.empty()) {
    const std::vector<double> m = numbers(value(matrix_key.c_str()));
    if (m.size() != 9)
      throw invalid_input(path,
                          fmt::format("MetaImage {} has {} values, not 9", matrix_key, m.size()));
    check_direction(path, "MetaImage " + matrix_key,
                    {{{m[0], m[1], m[2]}, {m[3], m[4], m[5]}, {m[6], m[7], m[8]}}},
                    /*scaled=*/false);
  }
  const std::string origin_key = first_of({"Offset", "Position", "Origin"});
  if (!origin_key.empty()) {
    const std::vector<double> o = numbers(value(origin_key.c_str()));
    if (o.size() != 3)
      throw invalid_input(
          path, fmt::format("MetaImage {} has {} values for a 3-D image", origin_key, o.size()));
    check_origin(path, "MetaImage " + origin_key, {o[0], o[1], o[2]});
  }

  // Uncompressed data must all be there (MetaIO reads what there is and leaves the rest), and
  // compressed data must be as long as CompressedDataSize says.
  if (field.count("HeaderSize")) return;  // an explicit skip: MetaIO's to judge
  std::string data_path = path;
  uint64_t offset = data_start < 0 ? 0 : static_cast<uint64_t>(data_start);
  if (value("ElementDataFile") != "LOCAL") {
    data_path = (fs::path(path).parent_path() / value("ElementDataFile")).string();
    offset = 0;
    std::error_code ec;
    if (!fs::exists(data_path, ec))
      throw invalid_input(path, fmt::format("MetaImage ElementDataFile names {}, which does not "
                                            "exist",
                                            value("ElementDataFile")));
  }
  // The header ran to the end of the file without a newline after ElementDataFile: no data.
  const auto held = [&] {
    return data_start < 0 && data_path == path ? uint64_t{0}
                                               : count_data_bytes(data_path, offset, false);
  };
  const std::string compressed = value("CompressedData");
  if (compressed == "True" || compressed == "true") {
    if (!field.count("CompressedDataSize")) return;  // MetaIO takes the rest of the file
    const uint64_t said = std::stoull(value("CompressedDataSize")), there = held();
    if (there != said)
      throw invalid_input(data_path, fmt::format("MetaImage CompressedDataSize is {} bytes but "
                                                 "the compressed data holds {} (truncated or "
                                                 "edited?)",
                                                 said, there));
    return;
  }
  const int bytes = element_bytes(value("ElementType"));
  if (bytes == 0 || size[0] * size[1] * size[2] > static_cast<double>(max_voxels)) return;
  const std::vector<double> channels = numbers(value("ElementNumberOfChannels"));
  // Sizes were checked above as whole numbers of at most nine digits; channels are ITK's to
  // refuse (a label image has one), so only a plausible count is multiplied in.
  const uint64_t per_voxel = channels.size() == 1 && channels[0] >= 1.0 && channels[0] <= 1024.0
                                 ? static_cast<uint64_t>(channels[0])
                                 : 1u;
  uint64_t expected = static_cast<uint64_t>(bytes) * per_voxel;
  for (int a = 0; a < 3; ++a)
    expected = saturating_product(expected, static_cast<uint64_t>(size[a]));
  const uint64_t there = held();
  if (there < expected)
    throw invalid_input(data_path, fmt::format("is truncated: the MetaImage header describes {} "
                                               "bytes of data but there are {}",
                                               expected, there));
}

}  // namespace lamina::io::detail
