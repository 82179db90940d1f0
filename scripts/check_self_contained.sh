#!/usr/bin/env bash
# Checks that nothing the project runs reads outside its checkout: no tracked file but the
# Markdown pages (which may say where a file came from) names `../shared` or a `shared/data`
# folder. The real organ data the tests use is the repository's own (tests/data). CI runs it
# (.ci/run), and so does the suite (Repository.ReadsNothingBesideIt); .ci/run also runs the
# suite with any ../shared beside the checkout hidden.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t hits < <(git ls-files -z | grep -zv '\.md$' | xargs -0 grep -lE '\.\./shared|shared/data|"shared", *"data"' -- 2>/dev/null |
  grep -vE '^(scripts/check_self_contained\.sh|\.ci/run)$' || true)
if ((${#hits[@]})); then
  echo "check_self_contained: these files name ../shared or shared/data (the project must read" \
    "only its own files; real data belongs in tests/data):" >&2
  for f in "${hits[@]}"; do grep -nE '\.\./shared|shared/data' -- "$f" | sed "s|^|  $f:|" >&2; done
  exit 1
fi
echo "check_self_contained: no tracked file reads outside the checkout"
