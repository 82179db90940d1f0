#pragma once
/// \file
/// A tool tip rendered to a haptic device: the god-object (Zilles & Salisbury 1995) for a
/// sphere, and a virtual coupling (Colgate, Stanley & Brown 1995) between it and the device.
/// The proxy follows the device's pose in steps of at most a quarter of its radius, each step
/// projected out of the current skin, so it stays on the side it came from (it cannot pop
/// through a thin edge, and it rests on the surface while the device sinks in). The coupling
/// spring F = k (proxy - device) is the force on the device, bounded by max_force_n and by
/// max_force_change_n per step; the tissue receives exactly -F, spread over the skin the proxy
/// touches (contact.h, spread_on_patch). docs/physics.md, "Haptic rendering".

#include <Eigen/Core>

#include "lamina/interact/skin_neighbourhood.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"

namespace lamina::interact {

/// The proxy's state between steps.
struct HapticProxy {
  bool placed = false;                                        ///< false until the first step
  Eigen::Vector3d proxy_mm = Eigen::Vector3d::Zero();         ///< the proxy sphere's centre
  Eigen::Vector3d device_force_mn = Eigen::Vector3d::Zero();  ///< the last force on the device
  bool touching = false;  ///< the proxy rests on the skin (its load went to the tissue)
  /// The device was inside the organ (its centre deeper than start_depth_limit_mm(radius)) when
  /// the tip came on:
  /// a proxy cannot know which side it entered from, so it is not placed, and nothing is felt
  /// or loaded, until the device is brought out.
  bool started_inside = false;
  double start_depth_mm = 0.0;  ///< how deep, when started_inside
  int32_t recheck_in = 0;       ///< steps until started_inside is checked again
  /// The touched surface's triangles near the proxy, kept between steps (kept, too, while the
  /// tip is off: the list checks itself against the surface's positions).
  SkinNeighbourhood near;
  /// Scratch: a display skin's vertex positions, when a start inside is checked on it.
  Eigen::MatrixX3d surface_mm;
};

/// While a device stays inside the organ its depth is checked every this many steps (16 ms at
/// 1 kHz: imperceptible as the device is brought out), not every step: the check scans the skin
/// (119 us a step on the paper-size skin, 1.2 ms on 25k triangles; sim_bench BM_DepthUnderSkin).
inline constexpr int32_t kInsideRecheckSteps = 16;

/// One step of the tip at positions x: moves the proxy towards tip.center_mm without entering
/// the surface `touch` names (the display skin, when the model has one, by default), updates
/// the device's force, and returns the tissue's load (empty when the proxy touches nothing). On
/// a display skin the load reaches the nodes by the embedding's weights (W transposed): the
/// same total force and moment. An inactive tip lifts the proxy off (next step it is placed
/// afresh); a device inside the organ is not placed (HapticProxy::started_inside).
ForceRoute couple_proxy(const Model& model, const Eigen::MatrixX3d& x, const ToolTip& tip,
                        HapticProxy& state, Touch touch = Touch::kDisplaySkin);

}  // namespace lamina::interact
