#!/usr/bin/env bash
# Installs every Debian 12 package Lamina needs to build, test and run (the team's STACK.md lists them).
# Idempotent: re-running it on a machine that already has everything is fast.
set -euo pipefail

pkgs=(
  cmake g++ make pkg-config ninja-build
  libeigen3-dev libinsighttoolkit5-dev libcgal-dev libopenvdb-dev libtbb-dev libimath-dev
  libxsimd-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  libnanoflann-dev libmeshoptimizer-dev libtet1.5-dev libgtest-dev libgmock-dev libbenchmark-dev
  zlib1g-dev
  # lamina validate's finite-element reference: CHOLMOD's supernodal Cholesky, on OpenBLAS
  # (Debian's reference BLAS made the same factorisation 10-16x slower)
  libsuitesparse-dev libopenblas0-pthread
  # every compile goes through ccache (cmake/ccache.cmake)
  ccache
  # render module, viewer and figures: GLFW + libepoxy + Dear ImGui + stb, Mesa's EGL
  # surfaceless (headless) and llvmpipe, Xvfb and xdotool (the viewer test), gnuplot (plots)
  libglfw3-dev libimgui-dev libepoxy-dev libstb-dev libgl-dev libegl-dev libegl-mesa0
  libgl1-mesa-dri xvfb xauth xdotool gnuplot-nox
  # embedding (docs/embedding.md, python.md, openigtlink.md): the Python module and its tests,
  # sweeps on a dask cluster, the OpenIGTLink server and the protocol's example clients
  pybind11-dev python3-dev python3-numpy python3-pytest python3-distributed python3-dask
  libopenigtlink-dev openigtlink-examples
  # fuzzing (scripts/fuzz.sh): clang with libFuzzer and the sanitizer runtimes, and its OpenMP
  clang-14 libclang-rt-14-dev libomp-14-dev
  # the formatting check (scripts/check_format.sh, .clang-format)
  clang-format-14
  # `lamina serve --web` (docs/web.md): Boost.Beast (header-only), TLS; the page's browser test
  # drives Debian's chromium (headless, swiftshader) with playwright-core from npm
  libboost1.74-dev libssl-dev chromium
)
# node and npm: the machine's own if it has them (a newer Node from elsewhere), else Debian's.
if ! command -v npm >/dev/null; then pkgs+=(nodejs npm); fi

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
  echo "lamina setup: installing ${#missing[@]} Debian packages: ${missing[*]}" >&2
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "lamina setup: all Debian packages present" >&2
fi

# The page's JavaScript (three.js, meshoptimizer's decoder) and its test drivers (playwright-core,
# iwer), from the npm registry at the versions web/package-lock.json pins; again only when the
# lockfile changed since the last install.
web="$(dirname "$0")/../web"
if [ ! -f "$web/node_modules/.package-lock.json" ] ||
   [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]; then
  echo "lamina setup: npm ci in web/ (package-lock.json)" >&2
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
else
  echo "lamina setup: web/node_modules matches package-lock.json" >&2
fi
