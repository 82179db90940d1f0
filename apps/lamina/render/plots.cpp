// Plots drawn by gnuplot from scripts written beside their data (so a researcher can restyle
// them); shared by `lamina figures` and `lamina validate`.
#include "plots.h"

#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"

extern char** environ;

namespace lamina::cli {

namespace fs = std::filesystem;

std::string find_gnuplot() {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / "gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  throw Error(ErrorKind::kUnavailable,
              "plots need gnuplot: apt-get install gnuplot-nox (scripts/setup.sh installs it)");
}

// Runs `gnuplot script` (no shell), then renames the PNG it wrote to a temporary name into place,
// so a failed plot never leaves a half-written picture.
static void plot(const std::string& gnuplot, const fs::path& script, const fs::path& tmp_png,
                 const fs::path& png) {
  const std::string script_s = script.string();
  char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>(script_s.c_str()), nullptr};
  pid_t pid = 0;
  if (posix_spawn(&pid, gnuplot.c_str(), nullptr, nullptr, argv, environ) != 0)
    throw Error(ErrorKind::kUnavailable, "cannot run " + gnuplot);
  int status = 0;
  waitpid(pid, &status, 0);
  std::error_code ec;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !fs::exists(tmp_png)) {
    fs::remove(tmp_png, ec);
    throw Error(ErrorKind::kOutput, png.string() + ": gnuplot failed on " + script_s);
  }
  fs::rename(tmp_png, png, ec);
  if (ec) throw Error(ErrorKind::kOutput, png.string() + ": cannot write: " + ec.message());
}

void write_text(const fs::path& path, const std::string& text) {
  write_file_atomically(path.string(), [&](std::ostream& out) { out << text; });
}

// gnuplot's string quoting: single quotes, with ' doubled.
std::string quote(const fs::path& p) {
  std::string s = "'";
  for (char c : p.string()) s += c == '\'' ? std::string("''") : std::string(1, c);
  return s + "'";
}

// Writes DIR/NAME.gp (`header`, the output line, then `body`) beside its data and draws
// DIR/NAME.png with it.
void draw_plot(const std::string& gnuplot, const fs::path& dir, const std::string& name,
               const std::string& header, const std::string& body) {
  const fs::path script = dir / (name + ".gp"), tmp = dir / (name + ".png.tmp");
  write_text(script, header + fmt::format("set output {}\n", quote(tmp)) + body);
  plot(gnuplot, script, tmp, dir / (name + ".png"));
}

const char* const kPlotStyle =
    "set terminal pngcairo size 1000,640 enhanced font 'DejaVu Sans,13' linewidth 2\n"
    "set datafile separator ','\n"
    "set key top right box opaque\n"
    "set grid lc rgb '#dddddd'\n"
    "set border lw 1\n";

}  // namespace lamina::cli
