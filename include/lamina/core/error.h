#pragma once
/// \file
/// The one exception type Lamina throws across its public API, and the process exit codes the
/// CLI maps it to (documented in docs/errors.md).

#include <stdexcept>
#include <string>

namespace lamina {

/// What went wrong, which also fixes the CLI's exit code.
enum class ErrorKind : int {
  kInternal = 1,      ///< a bug or an unexpected library failure
  kInvalidInput = 2,  ///< the user's input (file, option, data) cannot be used
  kOutput = 3,        ///< an output file could not be written
  kUnavailable = 4,   ///< something the command needs is missing here (a display, EGL, gnuplot)
  kUnstable = 5,      ///< the simulation blew up beyond recovery; what it did so far is written
};

/// An error with a message meant for a person: it names the file or option and the problem,
/// and where it can, says what to do next.
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }
  int exit_code() const { return static_cast<int>(kind_); }

 private:
  ErrorKind kind_;
};

/// Shorthand for the most common case: bad input named by `what` (a path or an option).
inline Error invalid_input(const std::string& what, const std::string& problem) {
  return Error(ErrorKind::kInvalidInput, what + ": " + problem);
}

}  // namespace lamina
