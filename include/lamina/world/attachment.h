#pragma once
/// \file
/// Attachments: connective tissue between two bodies where their skins meet (the gallbladder in
/// its bed on the liver, a ligament). Each tie joins a skin node of one body to the nearest
/// point of the other's skin, keeps the distance they had at rest with its own stiffness, tears
/// when it pulls harder than its strength, and is divided by a blade that passes between its
/// ends (a dissection).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace lamina::world {

/// How two bodies are attached (create_attachment()).
struct AttachmentDef {
  std::string name;                  ///< names it in reports; empty: "A-B" of the bodies' names
  int32_t body_a = -1, body_b = -1;  ///< slot indices (BodyId::index) ...
  uint32_t generation_a = 0, generation_b = 0;  ///< ... and their generations (stale: refused)
  /// A skin node of either body within this distance of the other's skin at rest is tied, mm.
  double reach_mm = 2.0;
  /// The tissue's stiffness per unit area of the attached skin, kPa/mm (mN/mm^2 per mm of
  /// stretch): each tie gets this times its node's share of skin area. Loose areolar tissue:
  /// about 1 kPa/mm (a 1 mm stretch of 1 mm^2 pulls with 1 mN).
  double stiffness_kpa_per_mm = 1.0;
  /// Stress at which the tissue tears, kPa: each tie tears past this times its area.
  /// Connective tissue fails at tens of kPa.
  double strength_kpa = 30.0;
};

/// One tie: skin node `node` of one body and the point of the other's skin with barycentric
/// `weights` on the triangle `corners` (ties are made from both bodies' nodes).
struct Tie {
  int32_t node_body = -1;     ///< the slot of the body `node` belongs to
  int32_t surface_body = -1;  ///< the slot of the body `corners` belong to
  int32_t node = -1;
  std::array<int32_t, 3> corners{};
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  double rest_mm = 0.0;            ///< their distance at rest
  double stiffness_n_per_m = 0.0;  ///< N/m = mN/mm
  double strength_mn = 0.0;        ///< it tears past this pull
  double area_mm2 = 0.0;           ///< the skin it holds
  bool divided = false;            ///< cut by a blade
  bool torn = false;               ///< pulled past its strength
  double force_mn = 0.0;           ///< last step's pull (> 0: stretched)
  bool active() const { return !divided && !torn; }
};

/// An attachment between two bodies.
struct Attachment {
  std::string name;
  int32_t body_a = -1, body_b = -1;  ///< slots
  uint32_t generation_a = 0, generation_b = 0;
  std::vector<Tie> ties;
  AttachmentDef def;
};

struct AttachmentSlot {
  Attachment attachment;
  uint32_t generation = 1;
  bool alive = false;
};

/// A blade's swept surface for one step: the quadrilateral swept by its edge from (a0, b0) to
/// (a1, b1), mm (interact::Scalpel's edge at two times).
struct BladeSweep {
  Eigen::Vector3d a0 = Eigen::Vector3d::Zero(), b0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d a1 = Eigen::Vector3d::Zero(), b1 = Eigen::Vector3d::Zero();
};

/// The distance from p to the surface the blade swept (two triangles), mm.
double distance_to_sweep(const BladeSweep& sweep, const Eigen::Vector3d& p);

}  // namespace lamina::world
