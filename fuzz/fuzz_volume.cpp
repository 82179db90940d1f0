// Fuzzes the volume reader (io::read_label_volume, through ITK): the first byte picks the format
// (the reader goes by the extension), the rest is the file. Any bytes give a volume or a
// lamina::Error. The voxel budget is small so that a header claiming a large image is refused
// instead of exhausting the fuzzer's memory limit, as a real budget does for a real machine.
#include "fuzz_input.h"
#include "lamina/core/error.h"
#include "lamina/io/label_volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".nii", ".nii.gz", ".nrrd", ".mha"};
  const std::string path = lamina::fuzz::write_input(data + 1, size - 1, kExtensions[data[0] % 4]);
  lamina::io::ReadVolumeOptions options;
  options.max_voxels = int64_t{1} << 20;
  try {
    lamina::io::read_label_volume(path, options);
  } catch (const lamina::Error&) {
  }
  return 0;
}
