// Fuzzes the model loader (io::load_model): any bytes give a Model or a lamina::Error.
#include "fuzz_input.h"
#include "lamina/core/error.h"
#include "lamina/io/model_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    lamina::io::load_model(lamina::fuzz::write_input(data, size, ".vtu"));
  } catch (const lamina::Error&) {
  }
  return 0;
}
