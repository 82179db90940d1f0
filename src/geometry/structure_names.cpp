// name_key, is_tumour_name, is_vessel_name and guess_role (structure_names.h).
#include "lamina/geometry/structure_names.h"

#include <cctype>

namespace lamina::geometry {
namespace {

bool has_any(const std::string& key, std::initializer_list<const char*> parts) {
  for (const char* p : parts)
    if (key.find(p) != std::string::npos) return true;
  return false;
}

}  // namespace

std::string name_key(const std::string& name) {
  std::string out;
  for (const char c : name)
    if (c != ' ' && c != '_' && c != '-')
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool is_tumour_name(const std::string& name) {
  return has_any(name_key(name), {"tumo", "lesion", "mass", "metasta", "carcinom", "hcc", "cancer",
                                  "neoplas", "nodule"});
}

bool is_vessel_name(const std::string& name) {
  // "ivc" and "pv" as whole keys only: as parts they occur in other words.
  const std::string n = name_key(name);
  return n == "ivc" || n == "pv" || n == "hv" ||
         has_any(n, {"vessel", "vein", "venous", "vena", "cava", "portal", "arter", "aorta", "bile",
                     "biliar", "duct", "vascul"});
}

VesselTreeKind vessel_tree_kind(const std::string& name) {
  if (is_tumour_name(name)) return VesselTreeKind::kNone;
  const std::string n = name_key(name);
  if ((has_any(n, {"portal"}) && has_any(n, {"hepatic"})) ||
      has_any(n, {"hepaticvessel", "livervessel"}))
    return VesselTreeKind::kMerged;
  if (n == "pv" || has_any(n, {"portalvein", "portal"})) return VesselTreeKind::kPortal;
  if (n == "hv" || has_any(n, {"hepaticvein"})) return VesselTreeKind::kHepatic;
  return VesselTreeKind::kNone;
}

bool is_vena_cava_name(const std::string& name) {
  if (is_tumour_name(name)) return false;
  const std::string n = name_key(name);
  return n == "ivc" || has_any(n, {"venacava", "cava"});
}

SurfaceRole guess_role(const std::string& name) {
  // A tumour's name first: "tumour thrombus in the portal vein" is a lesion.
  if (is_tumour_name(name)) return SurfaceRole::kTumour;
  if (is_vessel_name(name)) return SurfaceRole::kVessel;
  return SurfaceRole::kStructure;
}

}  // namespace lamina::geometry
