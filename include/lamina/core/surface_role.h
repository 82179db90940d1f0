#pragma once
/// \file
/// What an embedded surface is: stored with it in the model and its file, given once where the
/// surface enters (the build, a file, a cut), and read by every consumer (cut reports, plans,
/// colours, the viewer, the stream). No consumer infers it from a label number or a name
/// (DESIGN.md, "A world of bodies").

#include <cstdint>
#include <optional>
#include <string_view>

namespace lamina {

/// The role of an embedded surface.
enum class SurfaceRole : uint8_t {
  kDisplaySkin = 0,  ///< the organ's own surface at the segmentation's resolution
  kVessel = 1,       ///< a vessel or a tree of them: portal vein, hepatic veins, arteries, ducts
  kTumour = 2,       ///< a lesion: tumour, metastasis, cyst
  kStructure = 3,    ///< any other structure the organ carries (a gallbladder, a marker)
  kWound = 4,        ///< the faces a cut opened in the organ
};

/// True for the patient's anatomy carried inside the organ (vessels, tumours, other
/// structures): what a cut or a resection plan reports when it crosses it.
constexpr bool is_anatomy(SurfaceRole r) {
  return r == SurfaceRole::kVessel || r == SurfaceRole::kTumour || r == SurfaceRole::kStructure;
}

/// The role's name in files, JSON and messages: "display_skin", "vessel", "tumour",
/// "structure", "wound".
constexpr std::string_view role_name(SurfaceRole r) {
  switch (r) {
    case SurfaceRole::kDisplaySkin:
      return "display_skin";
    case SurfaceRole::kVessel:
      return "vessel";
    case SurfaceRole::kTumour:
      return "tumour";
    case SurfaceRole::kStructure:
      return "structure";
    case SurfaceRole::kWound:
      return "wound";
  }
  return "structure";
}

/// The role named `name` (role_name()'s spelling; "tumor" too), or none.
constexpr std::optional<SurfaceRole> role_from_name(std::string_view name) {
  for (const SurfaceRole r : {SurfaceRole::kDisplaySkin, SurfaceRole::kVessel, SurfaceRole::kTumour,
                              SurfaceRole::kStructure, SurfaceRole::kWound})
    if (role_name(r) == name) return r;
  if (name == "tumor") return SurfaceRole::kTumour;
  return std::nullopt;
}

}  // namespace lamina
