#pragma once
/// \file
/// Writing outputs so that nothing half-written is ever left behind: write to a temporary file in
/// the destination's directory, then rename it into place (atomic on POSIX file systems).

#include <functional>
#include <ostream>
#include <string>

namespace lamina {

/// Calls `write(stream)` on a temporary file beside `path`, then renames it to `path`.
/// If `write` throws, or the stream fails, the temporary file is removed and an Error
/// (ErrorKind::kOutput) naming `path` is thrown; an existing `path` is left untouched.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = false);

/// A fresh temporary path in the same directory as `path` (for writers that need a file name,
/// such as ITK's); the caller renames it with commit_temporary() or deletes it.
std::string temporary_path_beside(const std::string& path);

/// Renames `tmp` to `path`, or removes `tmp` and throws an Error naming `path`.
void commit_temporary(const std::string& tmp, const std::string& path);

}  // namespace lamina
