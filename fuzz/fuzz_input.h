#pragma once
// What every fuzz target shares: the readers take paths, so each input is written to a file of
// this process's own (in /dev/shm when it exists, so no disk is touched), and the one exception a
// reader may throw is lamina::Error. Anything else escaping (std::out_of_range, bad_alloc, a
// library's own exception) is a bug the fuzzer reports as a crash.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace lamina::fuzz {

inline std::string write_input(const uint8_t* data, size_t size, const std::string& extension) {
  static const std::string dir = std::filesystem::is_directory("/dev/shm")
                                     ? "/dev/shm"
                                     : std::filesystem::temp_directory_path().string();
  const std::string path = dir + "/lamina_fuzz_" + std::to_string(::getpid()) + extension;
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace lamina::fuzz
