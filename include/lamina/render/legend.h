#pragma once
/// \file
/// The legend of a picture with anatomy: the organ and each structure shown, with its colour, so
/// that the portal vein and the hepatic veins are told apart by name (the viewer's overlay and
/// `lamina render --legend`).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "lamina/render/frame.h"

namespace lamina::render {

/// One line of a legend.
struct LegendEntry {
  std::string name;
  Eigen::Vector3f color{0.0f, 0.0f, 0.0f};  ///< linear 0..1 RGB, as drawn
};

/// What a picture of `frame` shows: "organ" in the style's organ colour, then each visible
/// embedded structure (not the display skin) in its style colour. Empty when the model carries
/// no structures.
std::vector<LegendEntry> legend_entries(const Frame& frame);

/// The legend as a Dear ImGui window in the current ImGui frame, in the display's top-right
/// corner (or its bottom-right one): a colour swatch and the name per entry. Nothing for no
/// entries.
void legend_window(const std::vector<LegendEntry>& entries, bool bottom = false);

/// The legend drawn into the bound framebuffer (width x height pixels) with a Dear ImGui context
/// and OpenGL renderer of its own, its text sized for the picture: for `lamina render`. Needs a
/// current OpenGL 3.3 core context; leaves any other ImGui context current as it was.
void draw_legend(const std::vector<LegendEntry>& entries, int width, int height);

}  // namespace lamina::render
