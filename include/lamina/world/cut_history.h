#pragma once
/// \file
/// The cuts a world has taken, kept to take back one at a time (an undo) or all at once (a
/// reset): the world loop's and Python's World's (docs/world.md, undo_cut()). An undo puts back
/// every body the newest cut divided as it was just before it, on the clock of now and with the
/// parameters of now; the ties go back to those bodies' old numbering each as it is now (divided
/// or torn since by anything else stays so), but those the cut's stroke divided are joined again.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lamina/world/cut_body.h"
#include "lamina/world/world.h"

namespace lamina::world {

/// One cut, as an undo takes it back.
struct CutUndo {
  WorldBefore before;  ///< every body it divided, as it was just before it (take_cut()'s before)
  /// Per attachment slot, per tie: 1 if the cut's stroke divided it (divided_since()).
  std::vector<std::vector<uint8_t>> stroke_divided;
  int64_t tets = 0;  ///< the tetrahedra it divided
};

/// The cuts since the last reset.
struct CutHistory {
  static constexpr size_t kDepth = 8;  ///< the last cuts an undo can take back
  std::vector<CutUndo> undo;           ///< the newest last, at most kDepth
  WorldBefore oldest;                  ///< the cuts pushed off `undo`, kept for a reset only
};

/// Per attachment slot, per tie: 1 if the tie is divided.
std::vector<std::vector<uint8_t>> divided_flags(const World& world);

/// Per attachment slot, per tie: 1 if divided now and not in `before` (divided_flags() taken
/// before a stroke: the ties it divided).
std::vector<std::vector<uint8_t>> divided_since(const World& world,
                                                const std::vector<std::vector<uint8_t>>& before);

/// Pushes a cut on `history`; past kDepth the oldest is folded into history.oldest.
void push_cut(CutHistory& history, CutUndo cut);

/// Takes `cut` back (the newest of a history, popped by the caller): each body it holds is put
/// back (put_back(): renumbered again, its topology generation moving on, a grasp it held let
/// go), keeping its clock and its parameters (material, solver, routing) of now; the ties as the
/// header says. `cut` is emptied.
/// @return the ties joined again (those its stroke divided that were still divided)
int32_t undo_cut(World& world, CutUndo& cut);

/// Every body cut since the last reset put back as it was before its first cut, and the ties as
/// they were then (put_back()); `history` emptied. The slots put back are appended to `slots`
/// when given (a loop tells its consumers).
void put_back_all(World& world, CutHistory& history, std::vector<int32_t>* slots = nullptr);

}  // namespace lamina::world
