#include "lamina/core/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "lamina/core/error.h"
#include "support/temp_dir.h"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

size_t count_files(const fs::path& d) {
  return static_cast<size_t>(std::distance(fs::directory_iterator(d), fs::directory_iterator()));
}

TEST(AtomicFile, WritesAndReplaces) {
  const lamina::test::TempDir dir;
  const fs::path& d = dir.path;
  const std::string p = (d / "out.txt").string();
  lamina::write_file_atomically(p, [](std::ostream& o) { o << "first"; });
  lamina::write_file_atomically(p, [](std::ostream& o) { o << "second"; });
  EXPECT_EQ(slurp(p), "second");
  EXPECT_EQ(count_files(d), 1u);  // no temporary left beside it
}

TEST(AtomicFile, FailedWriteLeavesOldFileAndNoTemporary) {
  const lamina::test::TempDir dir;
  const fs::path& d = dir.path;
  const std::string p = (d / "model.vtu").string();
  lamina::write_file_atomically(p, [](std::ostream& o) { o << "good"; });
  EXPECT_THROW(lamina::write_file_atomically(p,
                                             [](std::ostream& o) {
                                               o << "half";
                                               throw std::runtime_error("interrupted");
                                             }),
               std::runtime_error);
  EXPECT_EQ(slurp(p), "good");
  EXPECT_EQ(count_files(d), 1u);
}

TEST(AtomicFile, MissingDirectoryIsAnOutputError) {
  try {
    lamina::write_file_atomically("/nonexistent_lamina_dir/x.txt", [](std::ostream& o) { o << 1; });
    FAIL() << "expected an error";
  } catch (const lamina::Error& e) {
    EXPECT_EQ(e.kind(), lamina::ErrorKind::kOutput);
    EXPECT_NE(std::string(e.what()).find("/nonexistent_lamina_dir/x.txt"), std::string::npos);
  }
}

TEST(AtomicFile, TemporaryKeepsCompoundExtension) {
  // ITK picks the writer from the extension: ".nii.gz" must survive whole.
  const lamina::test::TempDir dir;
  const fs::path& d = dir.path;
  const std::string tmp = lamina::temporary_path_beside((d / "liver.nii.gz").string());
  EXPECT_EQ(tmp.substr(tmp.size() - 7), ".nii.gz");
  EXPECT_EQ(fs::path(tmp).parent_path(), d);
}

}  // namespace
