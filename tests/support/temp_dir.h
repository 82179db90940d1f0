#pragma once
// A fresh directory under the system temp dir for one test, removed with everything in it.
// Only std types: the ITK test translation units include this too.

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <string>

namespace lamina::test {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    path = std::filesystem::temp_directory_path() /
           ("lamina_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  /// Path of `name` inside the directory.
  std::string file(const std::string& name) const { return (path / name).string(); }
  /// True when nothing has been written into it.
  bool empty() const { return std::filesystem::is_empty(path); }
};

}  // namespace lamina::test
