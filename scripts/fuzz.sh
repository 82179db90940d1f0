#!/usr/bin/env bash
# Builds the libFuzzer targets (CMake preset "fuzz", clang + ASan + UBSan) and runs each one for
# SECONDS (default 30) on a seed corpus generated here by the release `lamina` (docs/testing.md).
#   scripts/fuzz.sh [SECONDS] [TARGET...]     targets: volume model obj vtp scene checkpoint cut
#   scripts/fuzz.sh --ci                      CI's run: 3000 inputs per target from seed 1 on a
#                                             fresh corpus
# Findings go to build/fuzz/crashes/; the corpus grows in build/fuzz/corpus/ across runs.
# Exits non-zero if any target crashed, leaked, hung or ran out of memory.
set -euo pipefail
cd "$(dirname "$0")/.."
ci=0
if [ "${1:-}" = "--ci" ]; then
  ci=1
  shift
  set -- 0 "$@"
fi
seconds=${1:-30}
shift || true
targets=("$@")
((${#targets[@]})) || targets=(volume model obj vtp scene checkpoint cut)

lamina=build/release/lamina
if [ ! -x "$lamina" ]; then
  cmake --preset release >/dev/null
  cmake --build --preset release --target lamina_cli -j2
fi
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j2

# Seeds: small valid inputs of every kind, made by the tool itself (nothing copied in).
seeds=build/fuzz/seeds
if [ ! -f "$seeds/.done" ]; then
  rm -rf "$seeds"
  mkdir -p "$seeds"/{volume,model,obj,vtp,scene,checkpoint,cut}
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  "$lamina" -q phantom --size 16,16,16 --spacing 12 -o "$work/p.nii"
  "$lamina" -q phantom --size 12,12,12 --spacing 12 -o "$work/p.nii.gz"
  "$lamina" -q phantom --size 12,12,12 --spacing 12 -o "$work/p.nrrd"
  "$lamina" -q phantom --size 12,12,12 --spacing 12 -o "$work/p.mha"
  # fuzz_volume's first byte picks the format: 0 .nii, 1 .nii.gz, 2 .nrrd, 3 .mha.
  k=0
  for ext in nii nii.gz nrrd mha; do
    { printf "\\x0$k"; cat "$work/p.$ext"; } >"$seeds/volume/phantom_$k"
    k=$((k + 1))
  done
  # Text headers with every geometry field the raw header checks read (src/io/header_checks.h).
  { printf '\x02NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nspace: left-posterior-superior\n'
    printf 'space directions: (2,0,0) (0,2,0) (0,0,2)\nspace origin: (1,2,3)\n'
    printf 'space units: "mm" "mm" "mm"\nencoding: raw\n\n'
    head -c 64 /dev/zero; } >"$seeds/volume/nrrd_geometry"
  { printf '\x03ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n'
    printf 'ElementSpacing = 2 2 2\nOffset = 1 2 3\nTransformMatrix = 0 1 0 1 0 0 0 0 -1\n'
    printf 'ElementDataFile = LOCAL\n'
    head -c 64 /dev/zero; } >"$seeds/volume/mha_geometry"
  "$lamina" -q build "$work/p.nii" -o "$seeds/model/tiny.vtu" --skin-vertices 60 >/dev/null
  "$lamina" -q export "$seeds/model/tiny.vtu" -o "$seeds/obj/tiny_skin.obj"
  "$lamina" -q export "$seeds/model/tiny.vtu" -o "$seeds/obj/tiny_inner.obj" --layer 1
  cp tests/io/vtp/*.vtp "$seeds/vtp/"  # written by VTK itself, every encoding it has
  cp examples/*.json "$seeds/scene/"
  cat >"$work/scene.json" <<'JSON'
{"model": {"model": "tiny.vtu"}, "solver": {"mode": "local"},
 "tools": [{"vertex": 0, "force_n": [0, 0.1, 0], "end_s": 0.5}]}
JSON
  cp "$seeds/model/tiny.vtu" "$work/tiny.vtu"
  "$lamina" -q run "$work/scene.json" -o "$work/run" --stop-after 3 >/dev/null
  cp "$work/run/checkpoint.lmck" "$seeds/checkpoint/stopped.lmck"
  # A cut seed: no shift, the blade along +z 50 mm deep, a path across the block's middle.
  python3 -c "import struct,sys; sys.stdout.buffer.write(struct.pack('13d', 0,0,0, 0,0,1, 50, -5,21,-5, 45,19,-5))" >"$seeds/cut/across"
  touch "$seeds/.done"
fi

# ITK 5.2's NrrdIO leaks on some error paths (tests/sanitizers/lsan.supp).
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1"
mkdir -p build/fuzz/crashes
status=0
for t in "${targets[@]}"; do
  corpus="build/fuzz/corpus/$t"
  budget=(-max_total_time="$seconds")
  if ((ci)); then
    # A fixed seed and number of inputs from an empty corpus instead of a time budget, which
    # would explore more on a faster machine: CI repeats the run developers checked.
    corpus="build/fuzz/ci_corpus/$t"
    rm -rf "$corpus"
    budget=(-seed=1 -runs=3000)
  fi
  mkdir -p "$corpus"
  echo "fuzz_$t: ${budget[*]}" >&2
  if ! build/fuzz/fuzz/fuzz_"$t" "${budget[@]}" -timeout=10 -rss_limit_mb=2048 \
      -max_len=65536 -print_final_stats=1 -artifact_prefix="build/fuzz/crashes/$t-" \
      "$corpus" "$seeds/$t" 2>"build/fuzz/$t.log"; then
    echo "fuzz_$t FAILED: see build/fuzz/$t.log and build/fuzz/crashes/" >&2
    tail -40 "build/fuzz/$t.log" >&2
    status=1
  else
    grep -E "^stat::number_of_executed_units|^stat::new_units_added" "build/fuzz/$t.log" |
      sed "s/^/  fuzz_$t /" >&2
  fi
done
exit $status
