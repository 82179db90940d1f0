#pragma once
// Running the real `lamina` binary from tests, with stdout and stderr captured in files.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace lamina::test {

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Single quotes protect the paths from the shell; our temporary paths never contain one.
inline std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

/// Runs `LAMINA_CLI ARGS` in `cwd`; stdout and stderr go to files in `capture_dir` (kept apart
/// from `cwd` so checks for stray files there see only what lamina wrote).
inline RunResult run_cli(const std::string& cli, const std::filesystem::path& cwd,
                         const std::filesystem::path& capture_dir, const std::string& args) {
  const std::filesystem::path out = capture_dir / "stdout.txt", err = capture_dir / "stderr.txt";
  const std::string command = "cd " + quoted(cwd.string()) + " && " + quoted(cli) + " " + args +
                              " >" + quoted(out.string()) + " 2>" + quoted(err.string());
  const int status = std::system(command.c_str());
  RunResult r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.exit_code = 128 + WTERMSIG(status);
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

}  // namespace lamina::test
