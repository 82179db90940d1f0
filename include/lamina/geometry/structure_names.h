#pragma once
/// \file
/// What a structure's name says, read once where a structure enters (the command line, a scene,
/// Python, the C API): the role it is given when the user names none. Consumers read the role
/// stored with the structure (core/surface_role.h), never the name.

#include <string>

#include "lamina/core/surface_role.h"

namespace lamina::geometry {

/// A structure's name as compared: lower case, without spaces, '_' and '-' ("Portal_Vein" and
/// "portal vein" alike).
std::string name_key(const std::string& name);

/// True for names that say tumour: "tumour", "lesion", "metastasis", "HCC", ... (any case, with
/// or without '_', '-' or spaces).
bool is_tumour_name(const std::string& name);

/// True for names that say vessel: "portal vein", "hepatic veins", "vena cava", "IVC", "artery",
/// "aorta", "vessel", "bile duct", "biliary" ... (any case, with or without '_', '-' or spaces).
bool is_vessel_name(const std::string& name);

/// The vessel tree a structure's name says it is, for its territories (issue 63); kMerged: one
/// label holding both (Couinaud's segments read it; the functional remnant needs them apart).
enum class VesselTreeKind { kNone, kPortal, kHepatic, kMerged };

/// kMerged for a name with both "portal" and "hepatic", "hepatic vessel(s)" (MSD task 8's) or
/// "liver vessel(s)"; kPortal for "portal vein", "portal_veins", "PV"; kHepatic for "hepatic
/// vein(s)", "HV"; kNone for every other name (the vena cava, arteries, ducts, a tumour's).
VesselTreeKind vessel_tree_kind(const std::string& name);

/// True for the inferior vena cava's names: "vena cava", "IVC", "inferior_vena_cava" (where the
/// hepatic veins drain: their trees' roots, issue 63).
bool is_vena_cava_name(const std::string& name);

/// The role a structure called `name` gets when its role is not given: kTumour for a tumour's
/// name, kVessel for a vessel's, else kStructure.
SurfaceRole guess_role(const std::string& name);

}  // namespace lamina::geometry
