#pragma once
/// \file
/// The colour each embedded structure is drawn in, everywhere it is shown: the viewer, `lamina
/// render` and its legend, and the colour arrays of the .vtu model and the .pvd series for
/// ParaView. By name where the name says what it is, following 3D Slicer's and
/// TotalSegmentator's conventions where they tell the surgical trees apart, then by order: no two
/// structures of one model share a colour.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// An 8-bit sRGB colour.
using Rgb8 = std::array<uint8_t, 3>;

/// The liver's red-brown, for the organ (the skin, the display skin).
inline constexpr Rgb8 kOrganColor = {153, 56, 43};

/// The conventional colour of a structure called `name` (case, spaces, '_' and '-' ignored), or
/// none when the name says nothing known. Portal vein violet; hepatic veins Slicer's vein blue
/// (0, 151, 206); inferior vena cava TotalSegmentator's deep blue; arteries and the aorta red;
/// bile ducts Slicer's biliary green; the gallbladder Slicer's olive; tumours (tumour, tumor,
/// lesion, mass, metastasis, carcinoma, HCC, cancer) yellow; other vessels (vessel, vein) the
/// vein blue. Slicer gives every vein one blue; the portal vein differs here, as in surgical
/// planning pictures, so that the two trees of a liver can be told apart.
std::optional<Rgb8> color_by_name(const std::string& name);

/// One colour per embedded surface of `model`, in Model::embedded order: the display skin the
/// organ's; each structure its name's colour, or when the name is unknown or its colour already
/// taken by an earlier structure, the next colour of a fixed palette that no structure of the
/// model uses yet.
std::vector<Rgb8> structure_colors(const Model& model);

/// The colour of organ `index` of a world (docs/world.md) called `name`: its name's colour
/// (color_by_name: the gallbladder Slicer's olive), else the liver's red-brown for the first and
/// a palette apart from the structures' colours for the others (a plum, an ochre, a blue-grey).
Rgb8 organ_color(const std::string& name, size_t index);

}  // namespace lamina::model
