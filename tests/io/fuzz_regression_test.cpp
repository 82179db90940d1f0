// Every input a fuzzer ever crashed on (fuzz/regressions/TARGET/, docs/testing.md) is read again
// here by the same reader the fuzz target calls, in the normal build: it must give a result or a
// lamina::Error, never a crash, and the ones that crashed must be refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "lamina/core/error.h"
#include "lamina/io/checkpoint.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
const fs::path kRegressions = test::source_path("fuzz/regressions");

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes the input as the fuzz target does and runs its reader; returns whether it was refused.
bool refused(const std::string& target, const std::string& data, const test::TempDir& dir) {
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir.file(name), std::ios::binary) << bytes;
    return dir.file(name);
  };
  try {
    if (target == "volume") {
      if (data.empty()) return true;
      static const char* const kExtensions[] = {".nii", ".nii.gz", ".nrrd", ".mha"};
      io::ReadVolumeOptions options;
      options.max_voxels = int64_t{1} << 20;
      io::read_label_volume(
          write(std::string("input") + kExtensions[static_cast<uint8_t>(data[0]) % 4],
                data.substr(1)),
          options);
    } else if (target == "model") {
      io::load_model(write("input.vtu", data));
    } else if (target == "obj") {
      io::read_obj(write("input.obj", data));
    } else if (target == "vtp") {
      io::read_vtp(write("input.vtp", data));
    } else if (target == "scene") {
      io::parse_scene(data, "input.json");
    } else if (target == "checkpoint") {
      io::load_checkpoint(write("input.lmck", data));
    } else {
      ADD_FAILURE() << "unknown fuzz target folder " << target;
    }
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
    return true;
  }
  return false;
}

TEST(FuzzRegressions, EveryInputThatOnceCrashedIsNowARefusal) {
  ASSERT_TRUE(fs::is_directory(kRegressions)) << kRegressions;
  int count = 0;
  for (const auto& target : fs::directory_iterator(kRegressions)) {
    for (const auto& input : fs::directory_iterator(target.path())) {
      SCOPED_TRACE(input.path().string());
      test::TempDir dir;
      EXPECT_TRUE(refused(target.path().filename().string(), bytes_of(input.path()), dir));
      ++count;
    }
  }
  EXPECT_GE(count, 3);
}

}  // namespace
}  // namespace lamina
