// The raw NRRD header (src/io/header_checks.h). ITK's NRRD reader (teem) gives an axis without
// a spacing 1 mm, reads "space directions" whatever their shape, ignores "space units", and
// reads a short raw data section as far as it goes. Each of those is refused here first.
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "header_checks.h"
#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

namespace fs = std::filesystem;

// Bytes per value of NRRD's type names (NRRD0005 spec, "type").
int type_bytes(const std::string& t) {
  static const std::map<std::string, int> sizes = {{"signed char", 1},
                                                   {"int8", 1},
                                                   {"int8_t", 1},
                                                   {"uchar", 1},
                                                   {"unsigned char", 1},
                                                   {"uint8", 1},
                                                   {"uint8_t", 1},
                                                   {"short", 2},
                                                   {"short int", 2},
                                                   {"signed short", 2},
                                                   {"signed short int", 2},
                                                   {"int16", 2},
                                                   {"int16_t", 2},
                                                   {"ushort", 2},
                                                   {"unsigned short", 2},
                                                   {"unsigned short int", 2},
                                                   {"uint16", 2},
                                                   {"uint16_t", 2},
                                                   {"int", 4},
                                                   {"signed int", 4},
                                                   {"int32", 4},
                                                   {"int32_t", 4},
                                                   {"uint", 4},
                                                   {"unsigned int", 4},
                                                   {"uint32", 4},
                                                   {"uint32_t", 4},
                                                   {"longlong", 8},
                                                   {"long long", 8},
                                                   {"long long int", 8},
                                                   {"signed long long", 8},
                                                   {"signed long long int", 8},
                                                   {"int64", 8},
                                                   {"int64_t", 8},
                                                   {"ulonglong", 8},
                                                   {"unsigned long long", 8},
                                                   {"unsigned long long int", 8},
                                                   {"uint64", 8},
                                                   {"uint64_t", 8},
                                                   {"float", 4},
                                                   {"double", 8}};
  const auto it = sizes.find(t);
  return it == sizes.end() ? 0 : it->second;
}

std::string trim(std::string s) {
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t\r") + 1);
  return s;
}

// A number as NRRD writes it; "nan" (unknown) and "inf" parse, anything else is an error.
double number(const std::string& path, const std::string& field, const std::string& token) {
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (token.empty() || *end != '\0')
    throw invalid_input(
        path, fmt::format("NRRD field '{}': '{}' is not a number", field, token.substr(0, 40)));
  return v;
}

// "(x,y,z)" -> three numbers; "none" -> nullopt.
std::optional<std::array<double, 3>> vector_of(const std::string& path, const std::string& field,
                                               const std::string& token) {
  if (token == "none") return std::nullopt;
  if (token.size() < 2 || token.front() != '(' || token.back() != ')')
    throw invalid_input(path, fmt::format("NRRD field '{}': '{}' is not a vector like (1,0,0)",
                                          field, token.substr(0, 40)));
  std::array<double, 3> v{};
  std::istringstream in(token.substr(1, token.size() - 2));
  std::string part;
  int n = 0;
  while (std::getline(in, part, ',')) {
    if (n == 3)
      throw invalid_input(path, fmt::format("NRRD field '{}': {} has more than three components "
                                            "(Lamina reads 3-D space)",
                                            field, token.substr(0, 60)));
    v[n++] = number(path, field, trim(part));
  }
  if (n != 3)
    throw invalid_input(path, fmt::format("NRRD field '{}': {} does not have three components",
                                          field, token.substr(0, 60)));
  return v;
}

// Splits "a b c" into tokens, keeping "(x, y, z)" together even with spaces inside.
std::vector<std::string> tokens(const std::string& value) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (char c : value) {
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if ((c == ' ' || c == '\t') && depth == 0) {
      if (!cur.empty()) out.push_back(cur), cur.clear();
      continue;
    }
    if (c != ' ' || depth == 0) cur += c;
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace

void check_nrrd_header(const std::string& path, int64_t max_voxels) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return;  // ITK reports a missing or unreadable file in its own words
  std::string line;
  if (!std::getline(in, line) || line.rfind("NRRD000", 0) != 0)
    return;  // a detached .nhdr is
             // read the same way below
  std::map<std::string, std::string> field;
  for (int n = 2; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;  // the data follows
    if (n > 10000) throw invalid_input(path, "NRRD header has no end in its first 10000 lines");
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos) continue;  // key/value pairs: not geometry
    const size_t colon = line.find(": ");
    if (colon == std::string::npos)
      throw invalid_input(path, fmt::format("NRRD header line {} is not 'field: value'", n));
    field[line.substr(0, colon)] = trim(line.substr(colon + 2));
  }
  const std::streamoff data_start = in.tellg();
  const auto has = [&](const char* f) { return field.count(f) > 0; };

  if (!has("dimension") || !has("sizes") || !has("type")) return;  // ITK says what is missing
  const double dimension = number(path, "dimension", field["dimension"]);
  if (!(dimension >= 1.0 && dimension <= 16.0) || dimension != std::floor(dimension))
    throw invalid_input(path, fmt::format("NRRD 'dimension' must be a whole number 1..16, got '{}'",
                                          field["dimension"].substr(0, 40)));
  const int dims = static_cast<int>(dimension);
  const std::vector<std::string> sizes = tokens(field["sizes"]);
  if (static_cast<int>(sizes.size()) != dims)
    throw invalid_input(
        path, fmt::format("NRRD 'sizes' has {} values for dimension {}", sizes.size(), dims));
  uint64_t voxels = 1;
  for (const std::string& s : sizes) {
    const double v = number(path, "sizes", s);
    if (!(v >= 1.0) || v != std::floor(v) || v > 1e9)
      throw invalid_input(path, fmt::format("NRRD 'sizes' must be whole numbers >= 1, got '{}'",
                                            field["sizes"].substr(0, 60)));
    voxels = saturating_product(voxels, static_cast<uint64_t>(v));
  }

  // Voxel size and direction: from "space directions" (a vector per axis, "none" for a
  // non-spatial one) or else "spacings". Neither: ITK assumes 1 mm.
  std::vector<std::array<double, 3>> columns;
  if (has("space directions")) {
    const std::vector<std::string> vs = tokens(field["space directions"]);
    if (static_cast<int>(vs.size()) != dims)
      throw invalid_input(path, fmt::format("NRRD 'space directions' has {} entries for "
                                            "dimension {}",
                                            vs.size(), dims));
    for (const std::string& v : vs)
      if (auto c = vector_of(path, "space directions", v)) columns.push_back(*c);
    if (columns.size() == 3)
      check_direction(path, "NRRD 'space directions'", {columns[0], columns[1], columns[2]},
                      /*scaled=*/true);
    else if (!columns.empty())
      throw invalid_input(path, fmt::format("NRRD 'space directions' gives {} spatial axes; a "
                                            "volume has 3",
                                            columns.size()));
  }
  if (columns.empty()) {
    std::vector<double> spacings;
    if (has("spacings"))
      for (const std::string& t : tokens(field["spacings"])) {
        const double v = number(path, "spacings", t);
        if (!std::isnan(v)) spacings.push_back(v);  // nan: the axis has no spacing
      }
    if (spacings.size() < 3)
      throw invalid_input(path,
                          "NRRD header gives no voxel size ('space directions' or "
                          "'spacings'), and a reader would assume 1 mm: add it");
    check_spacing(path, "NRRD 'spacings'", {spacings[0], spacings[1], spacings[2]});
  }
  if (has("space origin")) {
    if (auto o = vector_of(path, "space origin", field["space origin"]))
      check_origin(path, "NRRD 'space origin'", *o);
  }
  if (has("space units"))
    for (const std::string& u : tokens(field["space units"]))
      if (u != "\"mm\"" && u != "\"\"")
        throw invalid_input(path, fmt::format("NRRD 'space units' is {}: Lamina reads "
                                              "millimetres, and a reader would ignore the unit; "
                                              "resample or rescale the header to mm",
                                              field["space units"].substr(0, 40)));

  // The data the header describes must all be there.
  if (voxels > static_cast<uint64_t>(max_voxels)) return;
  const int bytes = type_bytes(field["type"]);
  std::string encoding = has("encoding") ? field["encoding"] : "raw";
  const bool gzip = encoding == "gzip" || encoding == "gz";
  if (bytes == 0 || (!gzip && encoding != "raw")) return;  // other encodings: ITK's to judge
  std::string data_path = path;
  uint64_t offset = data_start < 0 ? 0 : static_cast<uint64_t>(data_start);
  const std::string file_field = has("data file") ? "data file" : has("datafile") ? "datafile" : "";
  if (!file_field.empty()) {
    const std::string name = field[file_field];
    if (name.find(' ') != std::string::npos || name.rfind("LIST", 0) == 0)
      return;  // a list of files or a pattern: ITK's to judge
    data_path = (fs::path(path).parent_path() / name).string();
    offset = 0;
    std::error_code ec;
    if (!fs::exists(data_path, ec))
      throw invalid_input(
          path, fmt::format("NRRD '{}' names {}, which does not exist", file_field, name));
  }
  if (has("byte skip")) {
    const double skip = number(path, "byte skip", field["byte skip"]);
    if (skip == -1.0) return;  // data at the end of the file: nothing to count
    if (!(skip >= 0.0 && skip <= 1e15) || skip != std::floor(skip))
      throw invalid_input(path, "NRRD 'byte skip' must be -1 or a whole number of bytes");
    if (!gzip) offset += static_cast<uint64_t>(skip);
  }
  const uint64_t expected = saturating_product(voxels, static_cast<uint64_t>(bytes));
  const uint64_t held = count_data_bytes(data_path, offset, gzip);
  if (held < expected)
    throw invalid_input(data_path, fmt::format("is truncated: the NRRD header describes {} bytes "
                                               "of {} data but there are {}",
                                               expected, gzip ? "inflated" : "raw", held));
}

}  // namespace lamina::io::detail
