#pragma once
// What every refused input owes the user (docs/errors.md): exit code 2, exactly one line on
// stderr starting "lamina: error: " that names the input and the problem, and no output or
// temporary file left behind.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "support/run_cli.h"

namespace lamina::test {

inline std::string lowercase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// Files under `dir` whose names start with "." (the tool's temporary files do).
inline std::vector<std::string> hidden_files(const std::filesystem::path& dir) {
  std::vector<std::string> found;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.path().filename().string().starts_with(".")) found.push_back(e.path().string());
  return found;
}

/// Everything wrong with run `r` as a refusal: each of `message_has` must appear in the message
/// (case-insensitive), each of `no_output` (relative to `work`) must not exist, and `work` must
/// hold no temporary file. Empty when the refusal is as it should be.
inline std::vector<std::string> refusal_problems(const RunResult& r,
                                                 const std::vector<std::string>& message_has,
                                                 const std::vector<std::string>& no_output,
                                                 const std::filesystem::path& work) {
  std::vector<std::string> problems;
  if (r.exit_code != 2) problems.push_back("exit code " + std::to_string(r.exit_code) + ", not 2");
  // Exactly one line: a script shows stderr to the user, and progress or library chatter
  // around the error would bury it.
  const auto lines = std::count(r.err.begin(), r.err.end(), '\n');
  if (lines != 1 || !r.err.ends_with("\n"))
    problems.push_back("stderr has " + std::to_string(lines) + " lines, not exactly one");
  if (r.err.find("lamina: error: ") != 0)
    problems.push_back("stderr does not start with 'lamina: error: '");
  for (const std::string& word : message_has)
    if (lowercase(r.err).find(lowercase(word)) == std::string::npos)
      problems.push_back("the message does not mention '" + word + "'");
  for (const std::string& name : no_output)
    if (std::filesystem::exists(work / name)) problems.push_back(name + " was written");
  for (const std::string& file : hidden_files(work))
    problems.push_back("temporary file left behind: " + file);
  return problems;
}

/// The problems as an indented list, for a failure message.
inline std::string as_list(const std::vector<std::string>& problems) {
  std::string report;
  for (const std::string& p : problems) report += "  - " + p + "\n";
  return report;
}

}  // namespace lamina::test
