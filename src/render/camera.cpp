#include "lamina/render/camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace lamina::render {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

struct Basis {
  Eigen::Vector3d eye, forward, right, up;
};

Basis basis(const Camera& c) {
  Basis b;
  b.eye = eye_position(c);
  b.forward = -eye_direction(c);
  b.right = b.forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  b.up = b.right.cross(b.forward);
  return b;
}

// Size of one pixel, mm, in the plane facing the eye at `depth_mm` in front of it.
double pixel_size(const Camera& c, int height, double depth_mm) {
  return 2.0 * depth_mm * std::tan(0.5 * c.fov_deg * kDegree) / std::max(height, 1);
}

}  // namespace

Camera fit_camera(const Model& model, double azimuth_deg, double elevation_deg) {
  Camera c;
  const Eigen::Vector3d lo = model.X.colwise().minCoeff(), hi = model.X.colwise().maxCoeff();
  c.target = 0.5 * (lo + hi);
  // The sphere around the box centre that holds every node (tighter than the box's diagonal)
  // fills about 95% of the view's height.
  const double radius =
      std::sqrt((model.X.rowwise() - c.target.transpose()).rowwise().squaredNorm().maxCoeff());
  c.azimuth_deg = azimuth_deg;
  c.elevation_deg = elevation_deg;
  c.distance_mm = radius / std::sin(0.5 * c.fov_deg * kDegree) / 0.95;
  return c;
}

Camera frame_beside_panels(const Model& model, int width, int height, int left_px, int right_px,
                           double azimuth_deg, double elevation_deg) {
  Camera c = fit_camera(model, azimuth_deg, elevation_deg);
  const double w = std::max(width, 1), h = std::max(height, 1);
  const double left = std::clamp<double>(left_px, 0.0, 0.8 * w);
  const double right = std::clamp<double>(right_px, 0.0, 0.8 * w - left);
  const double free = w - left - right;
  c.shift_x = (left - right) / w;  // the free columns' centre, from the viewport's, in half-widths
  // The sphere's half-angle must fit 95% of the free half-width as well as of the half-height.
  const double radius = c.distance_mm * std::sin(0.5 * c.fov_deg * kDegree) * 0.95;
  const double tan_half_free = std::tan(0.5 * c.fov_deg * kDegree) * free / h;
  const double sin_half =
      std::min(std::sin(0.5 * c.fov_deg * kDegree), std::sin(std::atan(tan_half_free)));
  c.distance_mm = radius / sin_half / 0.95;
  return c;
}

Eigen::Vector3d eye_direction(const Camera& c) {
  const double az = c.azimuth_deg * kDegree,
               el = std::clamp(c.elevation_deg, -89.0, 89.0) * kDegree;
  return {std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az), std::sin(el)};
}

Eigen::Vector3d eye_position(const Camera& c) {
  return c.target + c.distance_mm * eye_direction(c);
}

Eigen::Matrix4d view_matrix(const Camera& c) {
  const Basis b = basis(c);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = b.right.transpose();
  m.block<1, 3>(1, 0) = b.up.transpose();
  m.block<1, 3>(2, 0) = -b.forward.transpose();
  m.block<3, 1>(0, 3) = -m.block<3, 3>(0, 0) * b.eye;
  return m;
}

Eigen::Matrix4d projection_matrix(const Camera& c, double aspect, double scene_radius_mm) {
  const double far_plane = c.distance_mm + 1.5 * scene_radius_mm;
  const double near_plane = std::max(1e-3 * far_plane, c.distance_mm - 1.5 * scene_radius_mm);
  const double t = 1.0 / std::tan(0.5 * c.fov_deg * kDegree);
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = t / std::max(aspect, 1e-6);
  p(0, 2) = -c.shift_x;  // x_ndc += shift_x (w = -z)
  p(1, 1) = t;
  p(2, 2) = -(far_plane + near_plane) / (far_plane - near_plane);
  p(2, 3) = -2.0 * far_plane * near_plane / (far_plane - near_plane);
  p(3, 2) = -1.0;
  return p;
}

Ray pixel_ray(const Camera& c, int width, int height, double px, double py) {
  const Basis b = basis(c);
  const double tan_half = std::tan(0.5 * c.fov_deg * kDegree);
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  const double x = 2.0 * px / std::max(width, 1) - 1.0 - c.shift_x,
               y = 1.0 - 2.0 * py / std::max(height, 1);
  Ray r;
  r.origin = b.eye;
  r.direction =
      (b.forward + b.right * (x * tan_half * aspect) + b.up * (y * tan_half)).normalized();
  return r;
}

Eigen::Vector3d drag_in_view_plane(const Camera& c, int height, const Eigen::Vector3d& point,
                                   double dx, double dy) {
  const Basis b = basis(c);
  const double depth = std::max((point - b.eye).dot(b.forward), 1e-6);
  return (b.right * dx - b.up * dy) * pixel_size(c, height, depth);
}

void orbit(Camera& c, double d_azimuth_deg, double d_elevation_deg) {
  c.azimuth_deg = std::remainder(c.azimuth_deg + d_azimuth_deg, 360.0);
  c.elevation_deg = std::clamp(c.elevation_deg + d_elevation_deg, -89.0, 89.0);
}

void pan(Camera& c, int height, double dx, double dy) {
  c.target -= drag_in_view_plane(c, height, c.target, dx, dy);
}

void zoom(Camera& c, double factor) {
  c.distance_mm = std::clamp(c.distance_mm * factor, 1.0, 1e6);
}

}  // namespace lamina::render
