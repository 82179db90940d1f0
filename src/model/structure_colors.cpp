#include "lamina/model/structure_colors.h"

#include <algorithm>

#include "lamina/geometry/structure_names.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model {
namespace {

// Named colours. Slicer's General Anatomy terminology gives the generic vein (0, 151, 206), the
// biliary tree (0, 145, 30), the gallbladder (139, 150, 98) and arteries (216, 101, 79); the
// TotalSegmentator extension colours the portal vein and the vena cava with that same vein blue,
// and TotalSegmentator's own table the vena cava (0, 70, 200). The portal vein takes violet (as
// in surgical planning pictures) and arteries a saturated red, so that neither is confused with
// the hepatic veins or with the liver's red-brown.
constexpr Rgb8 kPortalVein = {150, 90, 230};
constexpr Rgb8 kHepaticVeins = {0, 151, 206};
constexpr Rgb8 kVenaCava = {0, 70, 200};
constexpr Rgb8 kArtery = {225, 45, 45};
constexpr Rgb8 kBile = {0, 145, 30};
constexpr Rgb8 kGallbladder = {139, 150, 98};
constexpr Rgb8 kTumour = {240, 200, 40};
// A cut's wound: the parenchyma's cut face, lighter than the organ's capsule.
constexpr Rgb8 kWound = {225, 105, 90};

// For structures without a known name, or whose name's colour an earlier one took: apart from
// the named colours above, from the organ's and from each other.
constexpr Rgb8 kPalette[] = {{240, 130, 30}, {210, 80, 200},  {60, 200, 180},  {235, 235, 235},
                             {130, 210, 60}, {250, 160, 190}, {120, 120, 255}, {200, 170, 120},
                             {40, 120, 120}, {255, 240, 150}, {160, 40, 110},  {90, 160, 255}};

bool has(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

std::optional<Rgb8> color_by_name(const std::string& name) {
  const std::string n = geometry::name_key(name);
  if (n == "wound") return kWound;
  if (has(n, "portal")) return kPortalVein;
  if (has(n, "hepatic") && (has(n, "vein") || has(n, "venous"))) return kHepaticVeins;
  if (has(n, "cava") || has(n, "ivc")) return kVenaCava;
  if (has(n, "arter") || has(n, "aorta")) return kArtery;
  if (has(n, "bile") || has(n, "biliar")) return kBile;
  if (has(n, "gall")) return kGallbladder;
  if (geometry::is_tumour_name(name)) return kTumour;
  if (has(n, "vessel") || has(n, "vein") || has(n, "venous")) return kHepaticVeins;
  return std::nullopt;
}

std::vector<Rgb8> structure_colors(const Model& model) {
  const int32_t skin = display_skin_index(model);
  std::vector<Rgb8> out(model.embedded.size(), kOrganColor);
  std::vector<Rgb8> taken;
  // Named structures first, in order, each keeping its colour unless an earlier one has it. The
  // role decides the display skin's, the wound's and a tumour's colour; a vessel's or other
  // structure's name, its convention's (the two venous trees of a liver told apart).
  std::vector<size_t> unnamed;
  for (size_t i = 0; i < model.embedded.size(); ++i) {
    const EmbeddedSurface& e = model.embedded[i];
    if (static_cast<int32_t>(i) == skin || e.role == SurfaceRole::kDisplaySkin) continue;
    std::optional<Rgb8> c;
    if (e.role == SurfaceRole::kWound)
      c = kWound;
    else if (e.role == SurfaceRole::kTumour)
      c = kTumour;
    else if (const auto named = color_by_name(e.name);
             named && *named != kTumour && *named != kWound)
      c = named;
    if (c && std::find(taken.begin(), taken.end(), *c) == taken.end()) {
      out[i] = *c;
      taken.push_back(*c);
    } else {
      unnamed.push_back(i);
    }
  }
  size_t next = 0;
  for (const size_t i : unnamed) {
    // The palette's next colour no named structure took; past its end, it cycles.
    Rgb8 c = kPalette[next % std::size(kPalette)];
    for (size_t tries = 0;
         tries < std::size(kPalette) && std::find(taken.begin(), taken.end(), c) != taken.end();
         ++tries)
      c = kPalette[++next % std::size(kPalette)];
    ++next;
    out[i] = c;
    taken.push_back(c);
  }
  return out;
}

Rgb8 organ_color(const std::string& name, size_t index) {
  if (const auto c = color_by_name(name)) return *c;
  static constexpr std::array<Rgb8, 3> kOthers = {{{128, 64, 96}, {196, 150, 80}, {110, 120, 150}}};
  return index == 0 ? kOrganColor : kOthers[(index - 1) % kOthers.size()];
}

}  // namespace lamina::model
