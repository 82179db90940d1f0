#!/usr/bin/env bash
# The cut with the anatomy (docs/benchmarks.md, issue 64's first target): TotalSegmentator's
# example labels (tests/data) on a clinical grid (512 x 512 x 129, scripts/clinical_liver.py),
# the liver built at paper size with a 98,524-triangle display skin and its portal vein, vena
# cava and gallbladder embedded (60k triangles), then a scalpel drawn across the whole organ
# (223 mm along x, 200 mm deep along +y, over 2 s) in `lamina run`; prints each run's median and
# largest cut event (summary.json), the events and tetrahedra divided, the structures reported.
#
#     scripts/anatomy_cut_case.sh [OUT_DIR (default out/anatomy_cut)] [RUNS (default 3)]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/anatomy_cut}
runs=${2:-3}
lamina=./build/release/lamina
mkdir -p "$out"
if [[ ! -f "$out/liver.vtu" ]]; then
  python3 scripts/clinical_liver.py tests/data/liver_totalseg_example_3mm_labels.nii.gz \
    "$out/labels.nii.gz"
  "$lamina" build "$out/labels.nii.gz" --label 1 \
    --embed 2=portal_vein,3=vena_cava,4=gallbladder -o "$out/liver.vtu" > "$out/build.log"
fi
cat > "$out/scene.json" <<'SCENE'
{
  "model": {"model": "liver.vtu"},
  "tools": [{"scalpel": {"path": [[-145, -280, 365], [78, -280, 365]], "direction": [0, 1, 0],
                         "depth_mm": 200, "start_s": 0.1, "end_s": 2.1}}],
  "output": {"frame_interval_s": 0.5}
}
SCENE
for r in $(seq "$runs"); do
  "$lamina" run "$out/scene.json" -o "$out/run$r" > "$out/run$r.log" 2>&1
  python3 - "$out/run$r/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"median {s['median_cut_ms']:.1f} ms, max {s['max_cut_ms']:.1f} ms, {s['cuts']} cuts, "
      f"{s['cut_tets']} tetrahedra, structures reported: "
      f"{', '.join(c['name'] for c in s.get('structures_cut', [])) or 'none'}")
PY
done
