#include "lamina/core/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "lamina/core/error.h"

namespace lamina {

namespace fs = std::filesystem;

std::string temporary_path_beside(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir))
    throw Error(ErrorKind::kOutput,
                path + ": cannot write: directory '" + dir.string() + "' does not exist");
  // Keep the whole extension ("liver.nii.gz" -> ".nii.gz") last: writers such as ITK choose the
  // format from it.
  const std::string name = p.filename().string();
  const size_t dot = name.find('.', 1);
  const std::string stem = dot == std::string::npos ? name : name.substr(0, dot);
  const std::string ext = dot == std::string::npos ? "" : name.substr(dot);
  return (dir / ("." + stem + ".tmp" + std::to_string(::getpid()) + "_" +
                 std::to_string(counter++) + ext))
      .string();
}

void commit_temporary(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(ErrorKind::kOutput, path + ": cannot write: " + ec.message());
  }
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary) {
  const std::string tmp = temporary_path_beside(path);
  try {
    {
      std::ofstream out(tmp, binary ? std::ios::binary : std::ios::out);
      if (!out) throw Error(ErrorKind::kOutput, path + ": cannot open for writing");
      write(out);
      out.flush();
      if (!out) throw Error(ErrorKind::kOutput, path + ": write failed (disk full?)");
    }
    commit_temporary(tmp, path);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

}  // namespace lamina
