#pragma once
// A whole input file as bytes, for the readers that parse from memory (model files, checkpoints).
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "lamina/core/error.h"

namespace lamina::io::detail {

/// The bytes of `path`; lamina::Error (kInvalidInput) "PATH: file not found" or "PATH: cannot
/// open the file for reading".
inline std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw invalid_input(path, std::filesystem::exists(path) ? "cannot open the file for reading"
                                                            : "file not found");
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace lamina::io::detail
