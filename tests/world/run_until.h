#pragma once
// Steps a world loop until it has come to rest as a test asks, up to the test's bound: "back at
// rest within N steps" checked without stepping on once it holds (the sanitizer suite runs these
// steps about ten times slower than the release suite). Rest is the loop's own (every body at
// rest: a velocity test, not a position passing by its rest) and the test's condition together.
#include <algorithm>
#include <cstdint>
#include <functional>

#include "lamina/world/world_loop.h"

namespace lamina::world::test_world {

inline WorldSnapshot run_until_rest(WorldLoop& loop, int64_t max_steps,
                                    const std::function<bool(const WorldSnapshot&)>& rested) {
  constexpr int64_t kChunk = 50;
  WorldSnapshot snap;
  for (int64_t k = 0; k < max_steps; k += kChunk) {
    loop.run_steps(std::min(kChunk, max_steps - k));
    loop.latest(snap);
    if (snap.converged && rested(snap)) break;
  }
  return snap;
}

}  // namespace lamina::world::test_world
