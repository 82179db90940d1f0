// The renderer, headless: the phantom's picture is an organ (not blank, shaded), a deformed state
// looks different, and the camera's rays and drags agree with its matrices.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"
#include "lamina/render/camera.h"
#include "lamina/render/legend.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"

namespace lamina::render {
namespace {

const Model& phantom_model() {
  static const Model m = [] {
    model::BuildOptions o;
    o.layers = 3;
    return model::build_model(geometry::make_phantom(), o).model;
  }();
  return m;
}

// The phantom with its anatomy: a display skin and two structures (vessels, tumour), small.
const Model& anatomy_model() {
  static const Model m = [] {
    model::BuildOptions o;
    o.display_triangles = 5000;
    o.structure_triangles = 3000;
    o.embed = {{.name = "vessels", .label = 2}, {.name = "tumour", .label = 3}};
    return model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}, .anatomy = true}), o)
        .model;
  }();
  return m;
}

// Share of pixels that differ from the background, and the spread of their brightness.
struct Coverage {
  double fraction = 0.0, luminance_sd = 0.0;
};
Coverage coverage(const Image& img, const Eigen::Vector4f& background) {
  double n = 0, sum = 0, sum2 = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t* p = img.pixel(x, y);
      int diff = 0;
      for (int c = 0; c < 3; ++c)
        diff = std::max(diff, std::abs(p[c] - static_cast<int>(std::lround(255 * background[c]))));
      if (diff <= 3) continue;
      const double lum = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
      ++n, sum += lum, sum2 += lum * lum;
    }
  Coverage c;
  c.fraction = n / (static_cast<double>(img.width) * img.height);
  c.luminance_sd = n > 1 ? std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n))) : 0.0;
  return c;
}

double differing_fraction(const Image& a, const Image& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.rgba.size(); i += 4)
    for (int c = 0; c < 3; ++c)
      if (std::abs(a.rgba[i + c] - b.rgba[i + c]) > 8) {
        ++n;
        break;
      }
  return static_cast<double>(n) / (a.rgba.size() / 4);
}

TEST(Camera, CentrePixelRayHitsTheTarget) {
  Camera c;
  c.target = {10, -20, 30};
  c.distance_mm = 250;
  const Ray r = pixel_ray(c, 640, 480, 320, 240);
  const Eigen::Vector3d to_target = (c.target - r.origin).normalized();
  EXPECT_NEAR(r.direction.dot(to_target), 1.0, 1e-12);
  EXPECT_NEAR((r.origin - c.target).norm(), 250.0, 1e-9);
}

TEST(Camera, ProjectionMapsAPixelRayBackToItsPixel) {
  Camera c = fit_camera(phantom_model());
  const int w = 800, h = 600;
  const Eigen::Matrix4d pv = projection_matrix(c, double(w) / h, 200.0) * view_matrix(c);
  for (auto [px, py] : {std::pair{100.0, 50.0}, {700.0, 550.0}, {400.0, 300.0}}) {
    const Ray r = pixel_ray(c, w, h, px, py);
    const Eigen::Vector3d p = r.origin + c.distance_mm * r.direction;
    const Eigen::Vector4d clip = pv * p.homogeneous();
    EXPECT_NEAR((clip.x() / clip.w() + 1) * 0.5 * w, px, 1e-6);
    EXPECT_NEAR((1 - clip.y() / clip.w()) * 0.5 * h, py, 1e-6);
  }
}

TEST(Camera, FramedBesidePanelsEveryNodeIsDrawnInTheFreeColumns) {
  // The viewer's 1400 x 900 window with its 460 px left panel: the organ in the columns right of
  // it, centred there, and the lens shift agreeing with the picking rays.
  const Model& m = phantom_model();
  const int w = 1400, h = 900, left = 460;
  const Camera c = frame_beside_panels(m, w, h, left, 0);
  EXPECT_NEAR(c.shift_x, 460.0 / 1400.0, 1e-12);
  const Eigen::Matrix4d pv = projection_matrix(c, double(w) / h, 300.0) * view_matrix(c);
  const auto pixel = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector4d clip = pv * p.homogeneous();
    return Eigen::Vector2d((clip.x() / clip.w() + 1) * 0.5 * w,
                           (1 - clip.y() / clip.w()) * 0.5 * h);
  };
  double lo = w, hi = 0;
  for (Eigen::Index i = 0; i < m.X.rows(); ++i) {
    const Eigen::Vector2d q = pixel(m.X.row(i).transpose());
    lo = std::min(lo, q.x()), hi = std::max(hi, q.x());
    ASSERT_GE(q.y(), 0.0);
    ASSERT_LE(q.y(), h);
  }
  EXPECT_GT(lo, left) << "no node under the panel";
  EXPECT_LT(hi, w);
  EXPECT_NEAR(pixel(c.target).x(), 0.5 * (left + w), 1e-6) << "centred in the free columns";
  // The ray through a pixel still projects back to it, and the target's pixel's ray hits it.
  for (auto [px, py] : {std::pair{500.0, 50.0}, {1300.0, 850.0}, {930.0, 450.0}}) {
    const Ray r = pixel_ray(c, w, h, px, py);
    const Eigen::Vector2d back = pixel(r.origin + c.distance_mm * r.direction);
    EXPECT_NEAR(back.x(), px, 1e-6);
    EXPECT_NEAR(back.y(), py, 1e-6);
  }
  // With nothing covered it is fit_camera at that aspect.
  const Camera plain = frame_beside_panels(m, w, h, 0, 0);
  EXPECT_EQ(plain.shift_x, 0.0);
  EXPECT_NEAR(plain.distance_mm, fit_camera(m).distance_mm, 1e-9);
}

TEST(Camera, AnteriorViewHasPatientLeftOnTheRightAndHeadUp) {
  Camera c;
  c.azimuth_deg = 0;
  c.elevation_deg = 0;
  const Eigen::Matrix4d v = view_matrix(c);
  EXPECT_NEAR(v(0, 0), 1.0, 1e-12);  // +x (patient left) is screen right
  EXPECT_NEAR(v(1, 2), 1.0, 1e-12);  // +z (superior) is screen up
  EXPECT_LT(eye_position(c).y(), c.target.y());
}

TEST(Camera, DragInViewPlaneIsPerpendicularToTheViewAndScalesWithDepth) {
  Camera c;
  c.distance_mm = 300;
  const Eigen::Vector3d d1 = drag_in_view_plane(c, 600, c.target, 60, 0);
  EXPECT_NEAR(d1.dot(eye_direction(c)), 0.0, 1e-9);
  // 60 px of a 600 px tall view at the target spans a tenth of the view's height there.
  EXPECT_NEAR(d1.norm(), 0.1 * 2 * 300 * std::tan(35.0 / 2 * M_PI / 180), 1e-9);
  const Eigen::Vector3d nearer = c.target + 150 * eye_direction(c);
  EXPECT_NEAR(drag_in_view_plane(c, 600, nearer, 60, 0).norm(), 0.5 * d1.norm(), 1e-9);
}

class Headless : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    try {
      context_ = new HeadlessContext;
      renderer_ = new Renderer;
    } catch (const Error& e) {
      FAIL() << e.what();
    }
  }
  static void TearDownTestSuite() {
    delete renderer_;
    delete context_;
  }
  static HeadlessContext* context_;
  static Renderer* renderer_;
};
HeadlessContext* Headless::context_ = nullptr;
Renderer* Headless::renderer_ = nullptr;

TEST_F(Headless, PhantomCoversAPlausibleShareWithShading) {
  ASSERT_NE(renderer_, nullptr);
  Frame f;
  f.model = &phantom_model();
  const Image img = render_image(*renderer_, f, fit_camera(phantom_model()), 480, 360);
  const Coverage c = coverage(img, f.style.background);
  EXPECT_GT(c.fraction, 0.15);
  EXPECT_LT(c.fraction, 0.85);
  EXPECT_GT(c.luminance_sd, 8.0) << "flat, unlit colour";
}

TEST_F(Headless, DeformedStateAndOverlaysRenderDifferently) {
  ASSERT_NE(renderer_, nullptr);
  const Model& m = phantom_model();
  const Camera cam = fit_camera(m);
  Frame rest;
  rest.model = &m;
  const Image a = render_image(*renderer_, rest, cam, 320, 240);
  const Image a2 = render_image(*renderer_, rest, cam, 320, 240);
  EXPECT_EQ(differing_fraction(a, a2), 0.0) << "rendering is not repeatable";

  // Push the superior half 15 mm towards the patient's left.
  Eigen::MatrixX3d x = m.X;
  const double mid_z = 0.5 * (m.X.col(2).minCoeff() + m.X.col(2).maxCoeff());
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    if (x(i, 2) > mid_z) x(i, 0) += 15.0;
  Frame dented = rest;
  dented.x = &x;
  EXPECT_GT(differing_fraction(a, render_image(*renderer_, dented, cam, 320, 240)), 0.02);

  Frame marked = rest;
  marked.rings.push_back({0, 3});
  marked.arrows.push_back(
      {m.X.row(0).transpose() - Eigen::Vector3d(0, 40, 0), m.X.row(0).transpose(), {}});
  EXPECT_GT(differing_fraction(a, render_image(*renderer_, marked, cam, 320, 240)), 0.001);

  Frame inside = rest;
  inside.style.inner = InnerLayers::kWireframe;
  inside.style.skin_alpha = 0.3f;
  inside.style.springs = true;
  EXPECT_GT(differing_fraction(a, render_image(*renderer_, inside, cam, 320, 240)), 0.02);
}

// The mean pixel of what differs from the background.
Eigen::Vector2d coverage_centroid(const Image& img, const Eigen::Vector4f& background) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t* p = img.pixel(x, y);
      int diff = 0;
      for (int c = 0; c < 3; ++c)
        diff = std::max(diff, std::abs(p[c] - static_cast<int>(std::lround(255 * background[c]))));
      if (diff > 3) sum += Eigen::Vector2d(x, y), ++n;
    }
  return n > 0 ? Eigen::Vector2d(sum / n) : Eigen::Vector2d(-1, -1);
}

TEST_F(Headless, StructuresShowThroughTheSkinWhereTheyAre) {
  ASSERT_NE(renderer_, nullptr);
  const Model& m = anatomy_model();
  ASSERT_EQ(m.embedded.size(), 3u);
  ASSERT_EQ(model::display_skin_index(m), 0);
  Frame shown;
  shown.model = &m;
  shown.style = default_style(m);
  EXPECT_LT(shown.style.skin_alpha, 1.0f) << "structures need a translucent skin by default";
  Frame hidden = shown;
  for (size_t i = 1; i < m.embedded.size(); ++i) hidden.style.embedded[i].visible = false;
  const Camera cam = fit_camera(m);
  const int w = 320, h = 240;
  const Image a = render_image(*renderer_, shown, cam, w, h);
  const Image b = render_image(*renderer_, hidden, cam, w, h);
  EXPECT_GT(differing_fraction(a, b), 0.01) << "the structures are not seen through the skin";

  // Every pixel that changed lies where a structure projects (its screen bounding box).
  const Eigen::Matrix4d pv =
      projection_matrix(cam, double(w) / h, 1.3 * scene_radius(m, cam)) * view_matrix(cam);
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (size_t i = 1; i < m.embedded.size(); ++i)
    for (Eigen::Index v = 0; v < m.embedded[i].V.rows(); ++v) {
      const Eigen::Vector4d c = pv * m.embedded[i].V.row(v).transpose().homogeneous();
      const Eigen::Vector2d px((c.x() / c.w() + 1) * 0.5 * w, (1 - c.y() / c.w()) * 0.5 * h);
      lo = lo.cwiseMin(px), hi = hi.cwiseMax(px);
    }
  size_t changed = 0, outside = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t *p = a.pixel(x, y), *q = b.pixel(x, y);
      if (std::max({std::abs(p[0] - q[0]), std::abs(p[1] - q[1]), std::abs(p[2] - q[2])}) <= 8)
        continue;
      ++changed;
      if (x < lo.x() - 2 || x > hi.x() + 2 || y < lo.y() - 2 || y > hi.y() + 2) ++outside;
    }
  EXPECT_GT(changed, 0u);
  EXPECT_LE(outside, changed / 100) << "pixels changed away from the structures";

  // Hiding one structure changes only part of what hiding both does.
  Frame no_tumour = shown;
  no_tumour.style.embedded[2].visible = false;
  const double one = differing_fraction(a, render_image(*renderer_, no_tumour, cam, w, h));
  EXPECT_GT(one, 0.001);
  EXPECT_LT(one, differing_fraction(a, b));
}

// Issue 46: each structure in its own colour by name, and a legend naming them in it: the
// picture's top-right corner holds a swatch of every structure's colour, and nothing else of the
// picture changes.
TEST_F(Headless, TheLegendNamesEachStructureInItsColour) {
  ASSERT_NE(renderer_, nullptr);
  const Model& m = anatomy_model();
  Frame f;
  f.model = &m;
  f.style = default_style(m);
  const std::vector<LegendEntry> entries = legend_entries(f);
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].name, "organ");
  EXPECT_EQ(entries[1].name, "vessels");
  EXPECT_EQ(entries[2].name, "tumour");
  // The style's colours are the structures' by name: vessels the vein blue, tumour yellow.
  EXPECT_EQ(model::structure_colors(m)[1], *model::color_by_name("vessels"));
  EXPECT_EQ(model::structure_colors(m)[2], *model::color_by_name("tumour"));
  const Camera cam = fit_camera(m);
  const int w = 640, h = 480;
  const Image plain = render_image(*renderer_, f, cam, w, h);
  const Image legend = render_image(
      [&](int ww, int hh) {
        renderer_->draw(f, cam, ww, hh);
        draw_legend(entries, ww, hh);
      },
      w, h);
  // Where the two differ: only in the top-right quarter.
  int changed = 0, elsewhere = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t *p = plain.pixel(x, y), *q = legend.pixel(x, y);
      if (std::max({std::abs(p[0] - q[0]), std::abs(p[1] - q[1]), std::abs(p[2] - q[2])}) <= 8)
        continue;
      ++changed;
      if (x < w / 2 || y > h / 2) ++elsewhere;
    }
  EXPECT_GT(changed, 500);
  EXPECT_EQ(elsewhere, 0);
  // Each entry's swatch: pixels of exactly its colour in the legend's corner.
  for (const LegendEntry& e : entries) {
    int found = 0;
    for (int y = 0; y < h / 2; ++y)
      for (int x = w / 2; x < w; ++x) {
        const uint8_t* p = legend.pixel(x, y);
        bool same = true;
        for (int c = 0; c < 3; ++c)
          same &= std::abs(p[c] - static_cast<int>(std::lround(255 * e.color[c]))) <= 2;
        found += same;
      }
    EXPECT_GT(found, 20) << e.name;
  }
  // No structures, no legend.
  Frame bare;
  bare.model = &phantom_model();
  EXPECT_TRUE(legend_entries(bare).empty());
}

TEST(StructureColors, NamesGiveTheConventionsAndNoTwoStructuresShareOne) {
  // Slicer's and TotalSegmentator's names, any case or separator.
  EXPECT_EQ(*model::color_by_name("Portal_Vein"), *model::color_by_name("portal vein"));
  EXPECT_EQ(*model::color_by_name("portal_vein_and_splenic_vein"),
            *model::color_by_name("portal vein"));
  EXPECT_NE(*model::color_by_name("portal vein"), *model::color_by_name("hepatic veins"));
  EXPECT_NE(*model::color_by_name("hepatic veins"), *model::color_by_name("inferior_vena_cava"));
  EXPECT_EQ(*model::color_by_name("IVC"), *model::color_by_name("inferior_vena_cava"));
  EXPECT_EQ(*model::color_by_name("liver_tumor"), *model::color_by_name("tumours"));
  EXPECT_EQ(*model::color_by_name("lesion 2"), *model::color_by_name("HCC"));
  EXPECT_EQ(*model::color_by_name("hepatic artery"), *model::color_by_name("aorta"));
  EXPECT_NE(*model::color_by_name("bile ducts"), *model::color_by_name("gallbladder"));
  EXPECT_FALSE(model::color_by_name("segment IV").has_value());
  // A model: the display skin (by its role) the organ's colour; two vein trees of one blue and
  // two unknown names all come out different; a tumour by its role, whatever its name.
  Model m;
  for (const char* name :
       {"display_skin", "vessels", "hepatic veins", "segment 2", "segment 3", "lesions"}) {
    EmbeddedSurface e;
    e.name = name;
    m.embedded.push_back(e);
  }
  m.embedded[0].role = SurfaceRole::kDisplaySkin;
  m.embedded[5].name = "segment 5";
  m.embedded[5].role = SurfaceRole::kTumour;
  const std::vector<model::Rgb8> c = model::structure_colors(m);
  ASSERT_EQ(c.size(), 6u);
  EXPECT_EQ(c[0], model::kOrganColor);
  EXPECT_EQ(c[1], *model::color_by_name("vessels"));
  EXPECT_EQ(c[5], *model::color_by_name("tumour"));
  for (size_t i = 1; i < c.size(); ++i)
    for (size_t j = i + 1; j < c.size(); ++j) EXPECT_NE(c[i], c[j]) << i << " " << j;
}

TEST_F(Headless, DisplaySkinOffDrawsTheSimulationsSkin) {
  ASSERT_NE(renderer_, nullptr);
  const Model& m = anatomy_model();
  Model bare = m;  // the same model without embedded surfaces: layer 0 is its skin
  bare.embedded.clear();
  const Camera cam = fit_camera(m);
  Frame display;
  display.model = &m;  // opaque skin, no structures: the skins alone are compared
  for (size_t i = 0; i < m.embedded.size(); ++i) display.style.embedded.push_back({false, {}});
  Frame simulation = display;
  simulation.style.display_skin = false;
  Frame layer0;
  layer0.model = &bare;
  const Image d = render_image(*renderer_, display, cam, 320, 240);
  const Image s = render_image(*renderer_, simulation, cam, 320, 240);
  const Image l = render_image(*renderer_, layer0, cam, 320, 240);
  EXPECT_EQ(differing_fraction(s, l), 0.0) << "display_skin = false is not layer 0's drawing";
  EXPECT_GT(differing_fraction(d, l), 0.01) << "the display skin was not drawn";
  // Both are the organ: about the same coverage of the picture.
  const double cd = coverage(d, display.style.background).fraction,
               cl = coverage(l, layer0.style.background).fraction;
  EXPECT_GT(cl, 0.1);
  EXPECT_NEAR(cd, cl, 0.1 * cl);
}

TEST_F(Headless, EmbeddedSurfacesAreDrawnWhereTheirPositionsSay) {
  ASSERT_NE(renderer_, nullptr);
  const Model& m = anatomy_model();
  const Camera cam = fit_camera(m);
  // The whole organ moved along the camera's right by a tenth of its size.
  const Eigen::Vector3d right = view_matrix(cam).block<1, 3>(0, 0).transpose();
  const double size = (m.X.colwise().maxCoeff() - m.X.colwise().minCoeff()).norm();
  const Eigen::MatrixX3d x = m.X.rowwise() + (0.1 * size * right).transpose();
  std::vector<Eigen::MatrixX3d> ex(m.embedded.size());
  Frame rest, moved, stale;  // stale: moved nodes, but embedded positions given at rest
  rest.model = moved.model = stale.model = &m;
  moved.x = stale.x = &x;
  for (size_t i = 0; i < m.embedded.size(); ++i) {
    model::embedded_positions(m.embedded[i], x, ex[i]);
    moved.embedded_x.push_back(&ex[i]);
    stale.embedded_x.push_back(&m.embedded[i].V);
  }
  rest.style = moved.style = stale.style = default_style(m);
  rest.style.skin_alpha = moved.style.skin_alpha = stale.style.skin_alpha = 1.0f;
  const Eigen::Vector4f bg = rest.style.background;
  const Eigen::Vector2d c0 = coverage_centroid(render_image(*renderer_, rest, cam, 320, 240), bg);
  const Eigen::Vector2d c1 = coverage_centroid(render_image(*renderer_, moved, cam, 320, 240), bg);
  const Eigen::Vector2d c2 = coverage_centroid(render_image(*renderer_, stale, cam, 320, 240), bg);
  EXPECT_GT(c1.x() - c0.x(), 10.0) << "the display skin did not follow its positions";
  EXPECT_NEAR(c1.y(), c0.y(), 3.0);
  // Given positions are the ones drawn (the display skin hides the moved simulation skin)...
  EXPECT_LT(std::abs(c2.x() - c0.x()), 2.0);
  // ... and none given: the renderer computes them from x, to the same picture.
  Frame computed = moved;
  computed.embedded_x.clear();
  EXPECT_EQ(differing_fraction(render_image(*renderer_, moved, cam, 320, 240),
                               render_image(*renderer_, computed, cam, 320, 240)),
            0.0);
}

TEST_F(Headless, WritesAPng) {
  ASSERT_NE(renderer_, nullptr);
  Frame f;
  f.model = &phantom_model();
  const Image img = render_image(*renderer_, f, fit_camera(phantom_model()), 64, 48);
  const std::string path = ::testing::TempDir() + "lamina_render_test.png";
  write_png(img, path);
  FILE* file = std::fopen(path.c_str(), "rb");
  ASSERT_NE(file, nullptr);
  unsigned char sig[8] = {};
  EXPECT_EQ(std::fread(sig, 1, 8, file), 8u);
  std::fclose(file);
  EXPECT_EQ(sig[1], 'P');
  EXPECT_EQ(sig[2], 'N');
  EXPECT_EQ(sig[3], 'G');
  EXPECT_THROW(render_image(*renderer_, f, fit_camera(phantom_model()), 0, 48), Error);
}

}  // namespace
}  // namespace lamina::render
