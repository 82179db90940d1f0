// Fuzzes the scene parser (io::parse_scene): any bytes give a Scene or a lamina::Error.
#include <string>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lamina::log::set_verbosity(-1);  // unknown keys warn; the fuzzer's output is not for warnings
  try {
    lamina::io::parse_scene(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const lamina::Error&) {
  }
  return 0;
}
