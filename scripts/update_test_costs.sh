#!/usr/bin/env bash
# Writes tests/test_costs.cmake from what ctest measured: each test's seconds in the release
# suite and in the sanitizer suite (build/release and build/asan, Testing/Temporary/
# CTestCostData.txt: ctest's running mean over the runs of that build tree). Run both suites
# first (ctest --preset release -j2; ctest --preset asan -j2), on a quiet machine. Tests under
# MIN seconds in both are left out (ctest's own order is as good for them).
set -euo pipefail
cd "$(dirname "$0")/.."
MIN=${MIN:-2}
release=build/release/Testing/Temporary/CTestCostData.txt
asan=build/asan/Testing/Temporary/CTestCostData.txt
for f in "$release" "$asan"; do
  [ -f "$f" ] || { echo "update_test_costs: $f is missing: run that suite first" >&2; exit 1; }
done
out=tests/test_costs.cmake
tmp=$(mktemp)
{
  cat <<'HEAD'
# Where ctest starts: the longest tests first, so that the two jobs of `ctest -j2` end together
# instead of one long test running alone at the end. Written by scripts/update_test_costs.sh
# from ctest's own measurements (CTestCostData.txt) of a release suite and a sanitizer suite on a
# 2-core machine; each suite orders its tests by its own column (a test's sanitizer slowdown
# ranges from 3x to 20x, so one order does not fit both). ctest's record of a finished run takes
# over in a build tree that has run before; a fresh clone (CI) starts from this table.
# Included after the tests are discovered (TEST_INCLUDE_FILES of tests/, tests/serve and
# tests/embedding); a test not built in a preset is ignored.
# name, release seconds, sanitizer seconds
set(lamina_test_costs
HEAD
  awk -v min="$MIN" '
    FNR == 1 { file++ }
    /^---/ { nextfile }
    NF == 3 { cost[$1, file] = $3; names[$1] = 1 }
    END {
      for (n in names) {
        r = cost[n, 1] + 0; a = cost[n, 2] + 0
        if (r >= min || a >= 3 * min) printf "  %s %.0f %.0f\n", n, r + 0.5, a + 0.5
      }
    }' "$release" "$asan" | sort -k3,3nr -k1,1
  cat <<'TAIL'
)
while(lamina_test_costs)
  list(POP_FRONT lamina_test_costs name release sanitizer)
  if(lamina_costs_sanitized)
    set_tests_properties(${name} PROPERTIES COST ${sanitizer})
  else()
    set_tests_properties(${name} PROPERTIES COST ${release})
  endif()
endwhile()
TAIL
} > "$tmp"
mv "$tmp" "$out"
echo "update_test_costs: wrote $out ($(grep -c '^  [A-Za-z]' "$out") tests)" >&2
