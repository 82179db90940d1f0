#!/usr/bin/env bash
# Checks that every tracked C and C++ file is laid out as .clang-format says (clang-format 14,
# Debian's). Lists the files that are not and exits 1; `scripts/check_format.sh --fix` formats
# them in place. CI runs it (.ci/run), and so does the suite (Format.EveryFileIsFormatted).
set -euo pipefail
cd "$(dirname "$0")/.."
format=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$format" ]; then
  echo "check_format: clang-format not found; install clang-format-14 (scripts/setup.sh)" >&2
  exit 2
fi
mapfile -t files < <(git ls-files '*.c' '*.h' '*.cpp' '*.hpp')
if [ "${1:-}" = "--fix" ]; then
  "$format" -i "${files[@]}"
  exit 0
fi
bad=()
for f in "${files[@]}"; do
  "$format" --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if ((${#bad[@]})); then
  echo "check_format: ${#bad[@]} of ${#files[@]} files are not formatted (.clang-format):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  echo "check_format: run scripts/check_format.sh --fix" >&2
  exit 1
fi
echo "check_format: all ${#files[@]} files formatted" >&2
