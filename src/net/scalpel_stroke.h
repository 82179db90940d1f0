#pragma once
// A scalpel driven over OpenIGTLink (`lamina serve --scalpel-device`): the poses of one stroke,
// from the first until the client says "up", pauses or goes, are the path its blade's tip
// traced; the stroke then cuts the organ along that path at once (world::OrganLoop::cut,
// as the viewer's scalpel does at a drag's release). Each cut goes down to every client as a
// STRING with what it divided and the vessels it crossed (docs/openigtlink.md).

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "igtl_wire.h"
#include "lamina/world/organ_loop.h"
#include "lamina/world/world_loop.h"

namespace lamina::net {

struct ScalpelStroke {
  int client = -1;                    ///< whose poses it follows; -1: no stroke under way
  std::vector<Eigen::Vector3d> tips;  ///< the blade's tip, model frame (LPS), mm
  Eigen::Vector3d axis_sum = Eigen::Vector3d::Zero();  ///< of the poses' blade axes
  double last_pose_s = 0.0;  ///< when the last pose came (a wall clock, s)

  /// A pose of the scalpel: its tip `tip` and blade axis `axis` (model frame), at `now_s`.
  void add(int from, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, double now_s);

  /// Ends the stroke: cuts along it (the blade `depth_mm` long, ending at the tip) and clears
  /// it. Returns what the log should say.
  std::string finish(world::OrganLoop& loop, double depth_mm);
  /// The same through `cut` (the blade's upper end along its path, its direction, its depth):
  /// a world's loop, whose cut() takes the same blade.
  using Cut = std::function<void(std::vector<Eigen::Vector3d>, const Eigen::Vector3d&, double)>;
  std::string finish(const Cut& cut, double depth_mm);
};

/// One cut as JSON text for a STRING message, positions in `frame`: {"cuts": ..., "cut_tets":
/// ..., "pieces": [{"volume_ml", "mass_g"}...], "structures_cut": [{"name", "position_mm",
/// "diameter_mm", "closed"}...]}.
std::string cut_event_text(const world::LoopSnapshot& snap, igtlink::Frame frame);
/// A world's: {"cuts": ..., "cut_tets": (every body's), "bodies": [{"name", "cut_tets",
/// "pieces", "structures_cut"}...]}, each body the last stroke divided.
std::string cut_event_text(const world::WorldSnapshot& snap, igtlink::Frame frame);

}  // namespace lamina::net
