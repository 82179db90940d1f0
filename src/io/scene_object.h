#pragma once
// Internal (not installed): the scene reader's pieces that a world scene (world_scene.cpp) reads
// its bodies and blades with, so that a body is read exactly as a scene file is.

#include <string>

#include "io/scene_keys.h"
#include "lamina/interact/scalpel.h"
#include "lamina/io/scene.h"

namespace lamina::io::detail {

/// The document, comments allowed; malformed JSON is "SOURCE: invalid JSON: at line L, ...".
json parse_scene_json(const std::string& json_text, const std::string& source_name);

/// A scene from the object `doc` found at `top` in the file ("" for the top level; "bodies[1]"
/// for a world's body, whose messages then name it: "bodies[1].material.young_modulus_kpa").
Scene read_scene_object(const json& doc, const std::string& source_name, const std::string& top);

/// A blade {"path", "direction", "depth_mm", "start_s", "end_s"}, read and checked as a scene's
/// {"scalpel": ...} tool is.
interact::Scalpel read_blade(const Reader& r, const json& data, const std::string& path);

}  // namespace lamina::io::detail
