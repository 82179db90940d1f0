// write_resection_picture (resection_picture.h): each surface a one-layer model in its colour,
// the bands as models of their own (the renderer colours a model, not a triangle), drawn in one
// picture: opaque structures first, then the translucent organ, then the plane.
#include "resection_picture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "lamina/model/structure_colors.h"
#include "lamina/render/camera.h"
#include "lamina/render/frame.h"
#include "lamina/render/legend.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"

namespace lamina::cli {
namespace {

const Eigen::Vector3f kBand(0.92f, 0.12f, 0.10f);          // within the margin
const Eigen::Vector3f kPlane(0.35f, 0.75f, 0.95f);         // the plane beyond it
const Eigen::Vector3f kTumourColour(0.94f, 0.78f, 0.16f);  // structure_colors' tumour yellow

struct Layer {
  Model model;
  render::Style style;
  std::string name;
};

Layer layer(const SurfaceMesh& s, const Eigen::Vector3f& colour, float alpha, bool two_sided,
            std::string name) {
  Layer l{render::mesh_model(s.V, s.F, two_sided), {}, std::move(name)};
  l.style.organ_color = colour;
  l.style.skin_alpha = alpha;
  l.style.inner = render::InnerLayers::kHidden;
  l.style.background = {1.0f, 1.0f, 1.0f, 1.0f};
  return l;
}

}  // namespace

void write_resection_picture(const std::string& path, const SurfaceMesh& organ,
                             const std::vector<PictureStructure>& structures,
                             const geometry::ResectionSurface& plane, double margin_mm,
                             const std::function<bool(const Eigen::Vector3d&)>& inside) {
  render::HeadlessContext context;
  const geometry::SideOf side(plane);
  std::vector<Layer> opaque, translucent;
  // The tumours' points (at most a few thousand) for the plane's band.
  std::vector<Eigen::Vector3d> tumour_points;
  for (const PictureStructure& s : structures) {
    if (s.role != SurfaceRole::kTumour) {
      const auto c = model::color_by_name(s.name).value_or(model::Rgb8{60, 200, 180});
      opaque.push_back(
          layer(s.surface, Eigen::Vector3f(c[0], c[1], c[2]) / 255.0f, 1.0f, false, s.name));
      continue;
    }
    std::vector<bool> near(static_cast<size_t>(s.surface.F.rows()));
    for (Eigen::Index f = 0; f < s.surface.F.rows(); ++f) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) c += s.surface.V.row(s.surface.F(f, k)).transpose() / 3.0;
      near[static_cast<size_t>(f)] = std::abs(side.signed_mm(c)) < margin_mm;
    }
    std::vector<bool> far(near.size());
    std::transform(near.begin(), near.end(), far.begin(), [](bool b) { return !b; });
    opaque.push_back(layer(geometry::triangle_subset(s.surface.V, s.surface.F, far), kTumourColour,
                           1.0f, false, s.name));
    opaque.push_back(layer(geometry::triangle_subset(s.surface.V, s.surface.F, near), kBand, 1.0f,
                           false, "within the margin"));
    const Eigen::Index step = std::max<Eigen::Index>(1, s.surface.V.rows() / 3000);
    for (Eigen::Index v = 0; v < s.surface.V.rows(); v += step)
      tumour_points.push_back(s.surface.V.row(v).transpose());
  }
  translucent.push_back(layer(organ, Eigen::Vector3f(0.60f, 0.22f, 0.17f), 0.3f, false, "organ"));

  // The plane: a fine grid over the organ's box, its triangles inside the organ, red where within
  // the margin of a tumour.
  const Eigen::Vector3d lo = organ.V.colwise().minCoeff().transpose(),
                        hi = organ.V.colwise().maxCoeff().transpose();
  if (plane.is_plane) {
    SurfaceMesh band, rest;
    geometry::plane_margin_band(plane, 0.5 * (lo + hi), (hi - lo).norm(), 160, tumour_points,
                                margin_mm, inside, band, rest);
    translucent.push_back(layer(rest, kPlane, 0.55f, true, "resection plane"));
    translucent.push_back(layer(band, kBand, 0.8f, true, "within the margin"));
  } else {
    translucent.push_back(layer({plane.V, plane.F}, kPlane, 0.55f, true, "resection surface"));
  }

  std::vector<Layer*> all;
  for (Layer& l : opaque) all.push_back(&l);
  for (Layer& l : translucent) all.push_back(&l);
  all.erase(std::remove_if(all.begin(), all.end(), [](Layer* l) { return l->model.X.rows() == 0; }),
            all.end());
  const Model& frame_model = translucent.front().model;  // the organ
  render::Camera camera = render::fit_camera(frame_model);
  std::vector<render::LegendEntry> legend;
  for (const Layer* l : all) {
    bool seen = false;
    for (const auto& e : legend) seen |= e.name == l->name;
    if (!seen) legend.push_back({l->name, l->style.organ_color});
  }
  std::vector<std::unique_ptr<render::Renderer>> renderers;
  for (size_t i = 0; i < all.size(); ++i) renderers.push_back(std::make_unique<render::Renderer>());
  const double radius = render::scene_radius(frame_model, camera) * 1.5;
  render::write_png(render::render_image(
                        [&](int w, int h) {
                          for (size_t i = 0; i < all.size(); ++i) {
                            render::Frame f;
                            f.model = &all[i]->model;
                            f.style = all[i]->style;
                            renderers[i]->draw(f, camera, w, h,
                                               {.clear = i == 0, .scene_radius_mm = radius});
                          }
                          render::draw_legend(legend, w, h);
                        },
                        1200, 900),
                    path);
}

}  // namespace lamina::cli
