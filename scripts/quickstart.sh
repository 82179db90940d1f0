#!/usr/bin/env bash
# Quick start on a fresh Debian 12 machine: install the dependencies, build Lamina, and run the
# main job on the built-in phantom (phantom -> multi-layer model -> the physical liver poked and
# back at rest -> exported meshes -> rendered pictures, no display needed).
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
"$lamina" run -o out/poke
"$lamina" export out/liver_model.vtu -o out/liver_skin.obj
"$lamina" export out/liver_model.vtu --layer 1 -o out/liver_layer1.obj
"$lamina" render out/liver_model.vtu --inner wireframe -o out/liver_model.png
"$lamina" render out/liver_phantom.nii.gz --at 1 --rings -o out/liver_poke.png
# The phantom with its anatomy: a vessel tree and a tumour carried inside by the tetrahedra.
"$lamina" phantom --labels -o out/liver_anatomy.nii.gz
"$lamina" build out/liver_anatomy.nii.gz --embed 2=vessels,3=tumour -o out/liver_anatomy.vtu
"$lamina" render out/liver_anatomy.vtu --legend -o out/liver_anatomy.png
echo
echo "Done. Pictures: out/liver_model.png, out/liver_poke.png, out/liver_anatomy.png. Open out/liver_model.vtu in"
echo "ParaView, or the meshes out/liver_skin.obj and out/liver_layer1.obj in any mesh viewer."
echo "With a display: $lamina view  (drag the organ with the mouse)."
echo "Run the tests with: ctest --preset release -j2"
