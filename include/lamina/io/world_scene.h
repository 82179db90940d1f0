#pragma once
/// \file
/// World scenes: several organs in one scene file, in contact and attached (docs/scenes.md,
/// "World scenes"; the world itself: docs/world.md). A scene file with a "bodies" array is a
/// world scene: each body is read exactly as a one-organ scene is (its model, material,
/// boundary and tools), under its name; "attachments" tie bodies where their skins meet,
/// "contact" sets the world's contact, "dissections" draw blades that divide the attachments'
/// ties they pass, and "solver" and "output" are the world's, shared by every body.

#include <memory>
#include <string>
#include <vector>

#include "lamina/core/progress.h"
#include "lamina/interact/scalpel.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/world/dissection.h"
#include "lamina/world/world.h"

namespace lamina::io {

/// A body of a world scene: its name and its scene (model, material, boundary, tools). A body
/// without "tools" has none (no default poke: the tools of a world are named where they act).
struct WorldBodyScene {
  std::string name;
  Scene scene;
};

/// An attachment of a world scene: two bodies by name and the tissue between them.
struct WorldAttachmentScene {
  std::string body_a, body_b;
  world::AttachmentDef def;  ///< its name, reach, stiffness and strength (body slots unset)
};

/// A parsed world scene.
struct WorldScene {
  std::string source;
  std::vector<WorldBodyScene> bodies;
  std::vector<WorldAttachmentScene> attachments;
  world::ContactOptions contact;
  std::vector<world::Dissection> dissections;  ///< blades that divide ties (dissection.h)
  sim::SolverOptions solver;                   ///< the world's: every body steps with it
  SceneOutput output;
};

/// Whether `json_text` is a world scene (an object with a "bodies" key); false for anything
/// else, malformed JSON included (parse_scene() then says what is wrong with it).
bool is_world_scene(const std::string& json_text);
/// The same, of the file at `path` (false if it cannot be read).
bool is_world_scene_file(const std::string& path);

/// Parses and validates a world scene: every body as parse_scene() reads a scene (messages
/// name it, "bodies[1].material.young_modulus_kpa: ..."), names unique and not empty, the
/// attachments' bodies existing and distinct, no body giving its own "solver" or "output"
/// (the world's are shared). A body's scalpels cut that body (`lamina run`,
/// world::advance_scalpels); a dissection divides the ties it passes.
/// \note Throws lamina::Error (kInvalidInput) "SOURCE: KEY.PATH: problem".
WorldScene parse_world_scene(const std::string& json_text, const std::string& source_name);

/// Reads and parses the world scene at `path`; relative paths in its bodies' models are taken
/// relative to the folder holding the file.
WorldScene load_world_scene(const std::string& path);

/// A world scene made ready to step: each body's model made and its scene prepared as a
/// one-organ scene's is (make_ready_scene()), the bodies added to the world (their rest overlap
/// checked) and the attachments tied.
struct ReadyWorld {
  world::World world;
  std::vector<ReadyScene> bodies;  ///< in the scene's order, beside `ids`
  std::vector<world::BodyId> ids;
  std::vector<world::AttachmentId> attachments;
};

/// Makes every body's model, prepares it, and fills the world.
/// \note Throws lamina::Error (kInvalidInput) "SOURCE: bodies[k] ('NAME'): problem" for a body
///   whose model cannot be made or prepared, "SOURCE: problem" for bodies overlapping at rest
///   or an attachment whose skins come nowhere near each other; nothing is kept.
/// @param scalpels_cut  whether the caller cuts with the bodies' scalpels (`lamina run`); if not,
///                      a body's scalpels are said to be ignored (a warning naming the scene)
std::unique_ptr<ReadyWorld> make_ready_world(const WorldScene& scene,
                                             const ReadVolumeOptions& read_options = {},
                                             const ProgressFn& progress = {},
                                             bool scalpels_cut = false);

}  // namespace lamina::io
