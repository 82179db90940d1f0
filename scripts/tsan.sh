#!/usr/bin/env bash
# ThreadSanitizer over the simulation thread, its viewer handoff, the world loop's and the web
# edge (docs/testing.md): builds tests/tsan/loop_handoff.cpp, world_handoff.cpp and
# web_session.cpp with the
# realtime loop's sources under -fsanitize=thread (preset "tsan"), makes a small model with the
# release CLI, and runs each for SECONDS (default 10).
# OMP_NUM_THREADS=1: GCC's libgomp is not instrumented; with one thread it starts no pool.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-10}
lamina=build/release/lamina
if [ ! -x "$lamina" ]; then
  cmake --preset release >/dev/null
  cmake --build --preset release --target lamina_cli -j2
fi
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j2
model=build/tsan/handoff_model.vtu
[ -f "$model" ] || "$lamina" -q build phantom -o "$model" --skin-vertices 400 >/dev/null
OMP_NUM_THREADS=1 TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
  build/tsan/tests/tsan/tsan_loop_handoff "$model" "$seconds"
# The world loop: two organs stepping in their thread, a viewer's frame loop forcing, dissecting,
# cutting and resetting them (tests/tsan/world_handoff.cpp).
# The world harness checks that cuts were made after its reset (at 60% of the run); under TSan a
# cut of its model takes seconds on a 2-core machine, and at 10 or 20 s none had finished after
# the reset on every run (2026-12-03): it runs at least 40 s (2-3 cuts after the reset).
world_seconds=$((seconds > 40 ? seconds : 40))
OMP_NUM_THREADS=1 TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
  build/tsan/tests/tsan/tsan_world_handoff "$model" "$world_seconds"
# `lamina serve --web`'s edge: the session polled as the serve loop does, beside the loop's
# thread and two pages' (tests/tsan/web_session.cpp).
OMP_NUM_THREADS=1 TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
  build/tsan/tests/tsan/tsan_web_session "$model" "$seconds"
