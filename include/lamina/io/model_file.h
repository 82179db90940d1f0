#pragma once
/// \file
/// Saving and loading a built Model as a VTK XML UnstructuredGrid (.vtu) that ParaView opens
/// directly. The layout is documented in docs/model_format.md.

#include <cstdint>
#include <string>

#include "lamina/model/model.h"

namespace lamina::io {

/// Writes `model` to `path` as an ASCII VTK XML UnstructuredGrid, atomically (temporary file,
/// then rename).
/// @param[in] model  the model to save, with its embedded surfaces; its rings are not stored
///   (load_model() leaves them for the caller to recompute)
/// @param[in] path   destination, normally ending in .vtu
/// \note Doubles are printed in their shortest round-trip form, so load_model() gives back every
///   value bit for bit. Writes format version 3 for a model with embedded surfaces, version 2
///   (readable by older builds) for one without. Throws lamina::Error (kOutput) if the file cannot
///   be written, (kInvalidInput) if an embedded surface's name is empty or holds a line break,
///   and (kInternal) if the model's arrays disagree in size.
void save_model(const Model& model, const std::string& path);

/// Reads a model written by save_model().
/// @param[in] path  a .vtu file written by save_model()
/// @return the model with every node, layer, spring, tetrahedron and embedded surface exactly as
///   saved; `rings` holds only `locality`, the rings themselves must be recomputed by the caller
/// \note Throws lamina::Error (kInvalidInput) with a one-line message "PATH: problem" for a
///   missing or truncated file, a file that is not a Lamina model or has an unsupported
///   format version, an array with the wrong type or number of values, an out-of-range index,
///   a spring whose kind disagrees with its cell type or its nodes' layers, a non-finite or
///   non-positive mass, rest length or stiffness, layer ranges that do not tile the points,
///   embedded surfaces that are inconsistent (names, counts, corners, weights not summing to 1,
///   a triangle on another surface's vertices, no tetrahedra to carry them), or contents that
///   disagree with the stored `content_crc32` (an edited or damaged file).
Model load_model(const std::string& path);

/// A CRC-32 of everything about a model that the simulation reads: positions, masses, fixed
/// flags, layers, faces, springs, tetrahedra and, when there are any, the embedded surfaces (a
/// model without them keeps the value it had before they were stored). save_model() stores it as
/// `content_crc32`; load_model() checks it, and a checkpoint records it to refuse a resume on
/// another model.
uint32_t model_fingerprint(const Model& model);

}  // namespace lamina::io
