// Fuzzes the VTK XML PolyData reader (io::read_vtp): any bytes give a mesh or a lamina::Error.
// Seeds: the files VTK itself wrote in each encoding (tests/io/vtp).
#include "fuzz_input.h"
#include "lamina/core/error.h"
#include "lamina/io/mesh_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    lamina::io::read_vtp(lamina::fuzz::write_input(data, size, ".vtp"));
  } catch (const lamina::Error&) {
  }
  return 0;
}
