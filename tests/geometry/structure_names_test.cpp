#include "lamina/geometry/structure_names.h"

#include <gtest/gtest.h>

namespace {

using namespace lamina;

TEST(StructureNames, ANameSuggestsItsRoleWhenNoneIsGiven) {
  for (const char* n :
       {"portal_vein", "Portal Vein", "hepatic_veins", "IVC", "vena cava", "inferior_vena_cava",
        "arteries", "aorta", "bile ducts", "vessels", "venous system"})
    EXPECT_EQ(geometry::guess_role(n), SurfaceRole::kVessel) << n;
  for (const char* n : {"tumour", "Tumor", "liver_tumours", "lesion", "metastases", "HCC"})
    EXPECT_EQ(geometry::guess_role(n), SurfaceRole::kTumour) << n;
  // A tumour's name wins (a tumour thrombus is a lesion); the rest are structures.
  EXPECT_EQ(geometry::guess_role("tumour thrombus in the portal vein"), SurfaceRole::kTumour);
  for (const char* n : {"gallbladder", "label 3", "marker", "cystic duct"})
    EXPECT_EQ(geometry::guess_role(n),
              n == std::string("cystic duct") ? SurfaceRole::kVessel : SurfaceRole::kStructure)
        << n;
}

TEST(StructureNames, ANameSaysWhichVesselTreeItIs) {
  using geometry::VesselTreeKind;
  for (const char* n : {"portal_vein", "Portal Veins", "PV", "portal"})
    EXPECT_EQ(geometry::vessel_tree_kind(n), VesselTreeKind::kPortal) << n;
  for (const char* n : {"hepatic_veins", "Hepatic Vein", "HV"})
    EXPECT_EQ(geometry::vessel_tree_kind(n), VesselTreeKind::kHepatic) << n;
  for (const char* n : {"portal and hepatic veins", "hepatic vessel", "liver_vessels"})
    EXPECT_EQ(geometry::vessel_tree_kind(n), VesselTreeKind::kMerged) << n;
  for (const char* n : {"vena cava", "IVC", "hepatic artery", "bile duct", "vessels",
                        "tumour thrombus in the portal vein"})
    EXPECT_EQ(geometry::vessel_tree_kind(n), VesselTreeKind::kNone) << n;
}

TEST(StructureNames, RolesAreSpelledOneWayEachAndReadBack) {
  for (const SurfaceRole r : {SurfaceRole::kDisplaySkin, SurfaceRole::kVessel, SurfaceRole::kTumour,
                              SurfaceRole::kStructure, SurfaceRole::kWound})
    EXPECT_EQ(role_from_name(role_name(r)), r);
  EXPECT_EQ(role_from_name("tumor"), SurfaceRole::kTumour);
  EXPECT_FALSE(role_from_name("vein").has_value());
  EXPECT_TRUE(is_anatomy(SurfaceRole::kVessel));
  EXPECT_FALSE(is_anatomy(SurfaceRole::kDisplaySkin));
  EXPECT_FALSE(is_anatomy(SurfaceRole::kWound));
}

}  // namespace
