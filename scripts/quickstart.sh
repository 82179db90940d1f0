#!/usr/bin/env bash
# Quick start on a fresh Debian 12 machine: install the dependencies, build Lamina, and run the
# main job on the built-in phantom (phantom -> multi-layer model -> summary -> exported meshes).
# Outputs go to ./out/.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake --preset release
cmake --build --preset release -j"$(nproc)"

lamina=./build/release/lamina
mkdir -p out
"$lamina" phantom -o out/liver_phantom.nii.gz
"$lamina" build out/liver_phantom.nii.gz -o out/liver_model.vtu
"$lamina" export out/liver_model.vtu -o out/liver_skin.obj
"$lamina" export out/liver_model.vtu --layer 1 -o out/liver_layer1.obj
echo
echo "Done. Open out/liver_model.vtu in ParaView, or the meshes out/liver_skin.obj and"
echo "out/liver_layer1.obj in any mesh viewer. Run the tests with: ctest --preset release -j2"
