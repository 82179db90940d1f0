#pragma once
// The resection picture `lamina resect -o DIR` writes (resection.png): the organ translucent, its
// structures, the resection plane's part inside the organ, and the margin bands: the plane red
// where it passes within the wanted margin of a tumour, each tumour red where it lies within the
// margin of the plane.

#include <functional>
#include <string>
#include <vector>

#include "lamina/geometry/plan_resection.h"
#include "lamina/geometry/surface_mesh.h"

namespace lamina::cli {

struct PictureStructure {
  std::string name;
  SurfaceMesh surface;
  SurfaceRole role = SurfaceRole::kVessel;  ///< tumours get the margin bands
};

/// Renders the picture without a window (EGL) and writes it as PNG.
/// @param[in] inside  whether a point (mm) lies in the organ: the plane is drawn where it does
/// \note Throws lamina::Error (kUnavailable) without EGL, (kOutput) if the file cannot be written.
void write_resection_picture(const std::string& path, const SurfaceMesh& organ,
                             const std::vector<PictureStructure>& structures,
                             const geometry::ResectionSurface& plane, double margin_mm,
                             const std::function<bool(const Eigen::Vector3d&)>& inside);

}  // namespace lamina::cli
