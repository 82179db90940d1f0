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
# Batches of files on every core (one clang-format per file took 27 s on a 2-core machine, three
# times in each CI run); each unformatted file is named in clang-format's own report.
set +e
report=$(printf '%s\0' "${files[@]}" |
  xargs -0 -P "$(nproc)" -n 32 "$format" --dry-run --Werror 2>&1 >/dev/null)
status=$?
set -e
mapfile -t bad < <(grep -oE '^[^:]+:[0-9]+:[0-9]+: error: code should be clang-formatted' \
  <<<"$report" | cut -d: -f1 | sort -u)
if ((status != 0 && ${#bad[@]} == 0)); then
  echo "check_format: $format failed:" >&2
  echo "$report" | head -n 20 >&2
  exit 2
fi
if ((${#bad[@]})); then
  echo "check_format: ${#bad[@]} of ${#files[@]} files are not formatted (.clang-format):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  echo "check_format: run scripts/check_format.sh --fix" >&2
  exit 1
fi
echo "check_format: all ${#files[@]} files formatted" >&2
