// Fuzzes the mesh reader (io::read_obj): any bytes give a mesh or a lamina::Error.
#include "fuzz_input.h"
#include "lamina/core/error.h"
#include "lamina/io/mesh_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    lamina::io::read_obj(lamina::fuzz::write_input(data, size, ".obj"));
  } catch (const lamina::Error&) {
  }
  return 0;
}
