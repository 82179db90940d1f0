#include "series_files.h"

#include <fmt/format.h>

#include <cctype>
#include <regex>

#include "lamina/core/atomic_file.h"

namespace lamina::cli {

namespace fs = std::filesystem;

void remove_stale_frames(const fs::path& frames, const std::set<std::string>& series,
                         int32_t keep) {
  static const std::regex kFrameName(R"((.+)_([0-9]{6})\.(vtp|obj))");
  static const std::regex kPiece(R"(piece[0-9]+)");  // a cut's pieces' series, made as they appear
  std::error_code ec;
  std::smatch match;
  for (const auto& e : fs::directory_iterator(frames, ec)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file(ec) && std::regex_match(name, match, kFrameName) &&
        (series.contains(match[1].str()) || std::regex_match(match[1].str(), kPiece)) &&
        std::stoi(match[2].str()) >= keep)
      fs::remove(e.path(), ec);
  }
}

std::string series_name(const std::string& surface, const std::set<std::string>& taken) {
  std::string name = surface;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
  if (name.empty() || name.front() == '.') name = "_" + name;
  const std::string base = name;
  for (int k = 2; taken.contains(name); ++k) name = base + "_" + std::to_string(k);
  return name;
}

void write_pvd(const fs::path& out, const std::string& name,
               const std::vector<std::pair<double, std::string>>& files) {
  write_file_atomically((out / (name + ".pvd")).string(), [&](std::ostream& f) {
    f << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
    for (const auto& [time, file] : files)
      f << fmt::format("    <DataSet timestep=\"{:.10g}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
                       time, file);
    f << "  </Collection>\n</VTKFile>\n";
  });
}

}  // namespace lamina::cli
