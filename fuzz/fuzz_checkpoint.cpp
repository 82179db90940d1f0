// Fuzzes the checkpoint loader (io::load_checkpoint): any bytes give a checkpoint or a
// lamina::Error, and never an allocation larger than the input.
#include "fuzz_input.h"
#include "lamina/core/error.h"
#include "lamina/io/checkpoint.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    lamina::io::load_checkpoint(lamina::fuzz::write_input(data, size, ".lmck"));
  } catch (const lamina::Error&) {
  }
  return 0;
}
