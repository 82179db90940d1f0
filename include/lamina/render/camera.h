#pragma once
/// \file
/// An orbit camera around the organ, and the matrices and picking rays it implies. Pure math (no
/// OpenGL), shared by the viewer, `lamina render` and the figures so that all show the same view.
/// Directions are in the model's patient frame (LPS: +x left, +y posterior, +z superior).

#include <Eigen/Core>

#include "lamina/model/model.h"

namespace lamina::render {

/// Looks at `target` from `distance_mm` away. Azimuth 0 looks from the anterior side (from -y)
/// with superior (+z) up; azimuth 90 looks from the patient's left; elevation > 0 looks down
/// from above.
struct Camera {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< orbit centre, mm
  double azimuth_deg = -30.0;
  double elevation_deg = 20.0;
  double distance_mm = 400.0;
  double fov_deg = 35.0;  ///< vertical field of view
  /// Where the target is drawn across the viewport: 0 at its centre, +1 at its right edge (a
  /// lens shift, so orbiting still turns about the target). A viewer whose panels cover part of
  /// the window frames the organ in the rest (frame_beside_panels).
  double shift_x = 0.0;
};

/// A camera at the default angles that frames the model's rest shape, with a margin.
Camera fit_camera(const Model& model, double azimuth_deg = -30.0, double elevation_deg = 20.0);

/// fit_camera for a width x height viewport whose columns [0, left_px) and [width - right_px,
/// width) are covered (by panels): the model's bounding sphere is centred in the columns between
/// and fills at most 95% of their width and of the height. left_px = right_px = 0 is fit_camera
/// at that aspect.
Camera frame_beside_panels(const Model& model, int width, int height, int left_px, int right_px,
                           double azimuth_deg = -30.0, double elevation_deg = 20.0);

/// Unit vector from the target towards the eye.
Eigen::Vector3d eye_direction(const Camera& camera);
/// The eye position, mm.
Eigen::Vector3d eye_position(const Camera& camera);

/// World-to-view transform (right-handed, the eye looks along -z of the view frame).
Eigen::Matrix4d view_matrix(const Camera& camera);
/// Perspective projection for a viewport of this aspect ratio (width / height); near and far
/// planes bracket a sphere of radius `scene_radius_mm` around the target.
Eigen::Matrix4d projection_matrix(const Camera& camera, double aspect, double scene_radius_mm);

/// The ray through pixel (px, py) of a width x height viewport (origin at the top left).
struct Ray {
  Eigen::Vector3d origin;     ///< the eye, mm
  Eigen::Vector3d direction;  ///< unit
};
Ray pixel_ray(const Camera& camera, int width, int height, double px, double py);

/// The world-space displacement of a mouse move of (dx, dy) pixels at the depth of `point`
/// (in the plane through `point` facing the eye): how far a grabbed point is dragged, mm.
Eigen::Vector3d drag_in_view_plane(const Camera& camera, int height, const Eigen::Vector3d& point,
                                   double dx, double dy);

/// Orbit by mouse motion (degrees per pixel), pan by a view-plane drag, and zoom by a factor.
void orbit(Camera& camera, double d_azimuth_deg, double d_elevation_deg);
void pan(Camera& camera, int height, double dx, double dy);
void zoom(Camera& camera, double factor);

}  // namespace lamina::render
