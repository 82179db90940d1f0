#pragma once
// Where the tests find the `lamina` binary, the source tree and its real organ data (tests/data):
// resolved at run
// time from the test program's own location, with the relative paths tests/CMakeLists.txt
// computes. No compile definition names the checkout, so a clone at another path compiles the
// same test sources to the same objects and ccache reuses them (cmake/ccache.cmake).
// Only std types: the ITK test translation units include this too.

#include <filesystem>
#include <string>

#if !defined(LAMINA_CLI_FROM_TEST) || !defined(LAMINA_SOURCE_FROM_TEST)
#error "tests/CMakeLists.txt defines the LAMINA_*_FROM_TEST paths for every test program"
#endif

namespace lamina::test {

/// `relative` (from the directory holding the running test program), made absolute.
inline std::filesystem::path beside_test_program(const char* relative) {
  static const std::filesystem::path dir =
      std::filesystem::canonical("/proc/self/exe").parent_path();
  return (dir / relative).lexically_normal();
}

/// The `lamina` command-line tool of this build.
inline std::string lamina_cli() {
  return beside_test_program(LAMINA_CLI_FROM_TEST).string();
}

/// A path inside the source tree, e.g. source_path("examples").
inline std::filesystem::path source_path(const std::string& relative) {
  return beside_test_program(LAMINA_SOURCE_FROM_TEST) / relative;
}

/// A file of tests/data: the real organ data the tests use, with its provenance and licences
/// (tests/data/PROVENANCE.md). The repository holds it, so a clone tests itself.
inline std::string real_data(const std::string& name) {
  return (source_path("tests/data") / name).string();
}

}  // namespace lamina::test
