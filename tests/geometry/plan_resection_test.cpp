// plan_resection against answers known by construction (the phantom's tumours are spheres and
// its vessels capsules of given radii), against counting the label volume's voxels on each side,
// and against a distance map of the tumour labels.
#include "lamina/geometry/plan_resection.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/volume_by_plane.h"
#include "lamina/io/label_volume_io.h"
#include "support/test_paths.h"

namespace lamina::geometry {
namespace {

LabelVolume carved_phantom() {
  return planning_phantom();
}

ResectionOptions carved_options() {
  return planning_phantom_options();
}

double diagonal(const GridFrame& f) {
  return std::sqrt(f.spacing_mm[0] * f.spacing_mm[0] + f.spacing_mm[1] * f.spacing_mm[1] +
                   f.spacing_mm[2] * f.spacing_mm[2]);
}

// The section of a capsule of radius r along direction d by a plane with normal n: an ellipse
// of area pi r^2 / |cos|, so the circle of that area has diameter 2 r / sqrt(|cos|).
double section_diameter(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r,
                        const Eigen::Vector3d& n) {
  return 2.0 * r / std::sqrt(std::abs((b - a).normalized().dot(n.normalized())));
}

TEST(PlanResection, ThePhantomsAnswersAreTheOnesItWasBuiltWith) {
  const LabelVolume v = carved_phantom();
  const double diag = diagonal(v.frame);
  // x = 30 mm, the left lobe resected: the plane crosses the portal vein's two left-lobe
  // branches and the left hepatic vein, and passes 20 mm from the subcapsular lesion (centre
  // x = 60, radius 10) and 75 mm from the right lobe's tumour (x = -60, radius 15).
  const SideOf side(plane_surface({30, 0, 0}, {1, 0, 0}));
  const ResectionPlan plan = plan_resection(v, side, carved_options());
  const ResectionReport& r = plan.report;
  ASSERT_EQ(r.tumours.size(), 2u);
  const TumourMargin& big = r.tumours[0];
  const TumourMargin& lesion = r.tumours[1];
  EXPECT_GT(big.volume_ml, lesion.volume_ml);
  EXPECT_NEAR(big.centre_mm.x(), -60.0, 0.5);
  EXPECT_EQ(big.side, "remnant");
  EXPECT_NEAR(big.margin_mm, 75.0, diag);
  EXPECT_FALSE(big.clear);  // not resected at all
  EXPECT_NEAR(lesion.centre_mm.x(), 60.0, 0.5);
  EXPECT_EQ(lesion.side, "resected");
  EXPECT_NEAR(lesion.margin_mm, 20.0, diag);
  EXPECT_TRUE(lesion.clear);         // 20 mm >= the default 10 mm
  EXPECT_FALSE(r.remnant_in_front);  // the larger side, x < 30

  // The crossings: where each capsule's axis meets the plane, with the section's diameter.
  struct Expected {
    const char* name;
    Eigen::Vector3d a, b;
    double r;
  };
  const Expected expected[] = {
      {"portal_vein", {22, 2, -2}, {62, -14, 14}, 3.0},   // left lobe, lateral
      {"portal_vein", {22, 2, -2}, {38, 18, 14}, 3.0},    // left lobe, posterior
      {"hepatic_veins", {10, 30, 38}, {40, -4, 34}, 3.0}  // left hepatic vein, into the lobe
  };
  ASSERT_EQ(r.crossings.size(), 3u);
  for (const Expected& e : expected) {
    const double t = (30.0 - e.a.x()) / (e.b.x() - e.a.x());
    const Eigen::Vector3d at = e.a + t * (e.b - e.a);
    const double d = section_diameter(e.a, e.b, e.r, {1, 0, 0});
    int found = 0;
    for (const StructureCrossing& c : r.crossings) {
      if (c.name != e.name || (c.position_mm - at).norm() > diag) continue;
      ++found;
      EXPECT_NEAR(c.diameter_mm, d, diag) << e.name << " at " << at.transpose();
      EXPECT_NEAR(c.position_mm.x(), 30.0, 1e-9);  // on the plane
    }
    EXPECT_EQ(found, 1) << e.name << " at " << at.transpose();
  }
  EXPECT_EQ(r.remnant_pieces.size(), 1u);
  EXPECT_NEAR(r.remnant_ml + r.resected_ml, r.whole_ml, 1e-9 * r.whole_ml);
  EXPECT_NEAR(r.flr_percent, 100.0 * r.remnant_ml / r.whole_ml, 1e-9);
}

// The organ's voxels (label `label`, every label > 0 for 0) in front of a plane, each voxel the
// plane passes through cut into six tetrahedra (along its diagonal) and clipped exactly by
// volume_by_plane: the partial-voxel volume by another route.
struct Clipped {
  double front_mm3 = 0.0;
  double straddling_mm3 = 0.0;  // the voxels the plane passes through
};
Clipped clipped_front(const LabelVolume& v, int32_t label, const Eigen::Vector3d& point,
                      const Eigen::Vector3d& normal) {
  const GridFrame& f = v.frame;
  const Eigen::Vector3d n = normal.normalized();
  const double half_diagonal =
      0.5 * std::sqrt(f.spacing_mm[0] * f.spacing_mm[0] + f.spacing_mm[1] * f.spacing_mm[1] +
                      f.spacing_mm[2] * f.spacing_mm[2]);
  double h = 0.0;  // half a voxel's extent across the plane
  for (int a = 0; a < 3; ++a)
    h += 0.5 * f.spacing_mm[a] *
         std::abs(n.dot(Eigen::Vector3d(f.direction[a], f.direction[3 + a], f.direction[6 + a])));
  std::vector<Eigen::Vector3d> corners;
  Clipped out;
  double& front = out.front_mm3;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int32_t l = v.labels[static_cast<size_t>(f.index(i, j, k))];
        if (label == 0 ? l == 0 : l != label) continue;
        const auto c =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const double s = (Eigen::Vector3d(c[0], c[1], c[2]) - point).dot(n);
        if (std::abs(s) < h) out.straddling_mm3 += f.voxel_volume_mm3();
        if (std::abs(s) > half_diagonal) {
          front += s > 0.0 ? f.voxel_volume_mm3() : 0.0;
          continue;
        }
        for (int corner = 0; corner < 8; ++corner) {
          const auto p = f.to_physical(static_cast<double>(i) + (corner & 1) - 0.5,
                                       static_cast<double>(j) + (corner >> 1 & 1) - 0.5,
                                       static_cast<double>(k) + (corner >> 2 & 1) - 0.5);
          corners.emplace_back(p[0], p[1], p[2]);
        }
      }
  // Kuhn's six tetrahedra of a cube, each along the diagonal from corner 0 to corner 7.
  const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                          {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  const auto boxes = static_cast<Eigen::Index>(corners.size() / 8);
  Eigen::MatrixX3d X(boxes * 8, 3);
  Eigen::MatrixX4i T(boxes * 6, 4);
  for (Eigen::Index b = 0; b < boxes; ++b) {
    for (int c = 0; c < 8; ++c) X.row(8 * b + c) = corners[static_cast<size_t>(8 * b + c)];
    for (int t = 0; t < 6; ++t)
      for (int c = 0; c < 4; ++c) T(6 * b + t, c) = static_cast<int>(8 * b + kuhn[t][c]);
  }
  front += volume_by_plane(X, T, point, normal).front_mm3;
  return out;
}

TEST(PlanResection, VolumesMatchTheVoxelsOnEachSide) {
  // The phantom with its anatomy inside the organ's label (the organ: every label > 0, 1.5 mm
  // voxels), and the TotalSegmentator liver (label 1 of its multi-label example, 3 mm): for
  // planes through the organ at angles, the partial-voxel volumes against the voxels clipped
  // as tetrahedra, and against counting voxel centres on each side. The count's own error is up
  // to half a voxel's thickness across the section (a plane parallel to the voxel faces, half
  // way between centre and face): 1.06-1.27% of a side here at 1.5 mm, so that is the bound.
  PhantomOptions po;
  po.anatomy = true;
  const LabelVolume phantom = make_phantom(po);
  const LabelVolume total =
      io::read_label_volume(test::real_data("liver_totalseg_example_3mm_labels.nii.gz"));
  struct Case {
    const LabelVolume* v;
    std::vector<int32_t> organ;
    int32_t label;  // for the voxel count
  };
  for (const Case& c : {Case{&phantom, {}, 0}, Case{&total, {1}, 1}}) {
    // The organ's centroid and three planes through it or beside it.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    int64_t n = 0;
    const GridFrame& f = c.v->frame;
    for (int64_t k = 0; k < f.size[2]; ++k)
      for (int64_t j = 0; j < f.size[1]; ++j)
        for (int64_t i = 0; i < f.size[0]; ++i) {
          const int32_t l = c.v->labels[static_cast<size_t>(f.index(i, j, k))];
          if (c.label == 0 ? l == 0 : l != c.label) continue;
          const auto p =
              f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
          centre += Eigen::Vector3d(p[0], p[1], p[2]);
          ++n;
        }
    centre /= static_cast<double>(n);
    const Eigen::Vector3d normals[] = {{1, 0, 0}, {1, 1, 0}, {0.3, -0.5, 0.8}};
    const double shifts[] = {0.0, 25.0, -20.0};
    for (int p = 0; p < 3; ++p) {
      const Eigen::Vector3d point = centre + shifts[p] * normals[p].normalized();
      ResectionOptions o;
      o.organ_labels = c.organ;
      const ResectionPlan plan = plan_resection(*c.v, SideOf(plane_surface(point, normals[p])), o);
      const PlaneSides count = voxel_volume_by_plane(*c.v, c.label, point, normals[p]);
      const Clipped clipped = clipped_front(*c.v, c.label, point, normals[p]);
      const double split = clipped.front_mm3;
      const double whole = count.front_mm3 + count.back_mm3;
      const ResectionReport& r = plan.report;
      const double front = (r.remnant_in_front ? r.remnant_ml : r.resected_ml) * 1000.0;
      const double back = (r.remnant_in_front ? r.resected_ml : r.remnant_ml) * 1000.0;
      const std::string where = c.v->source + " plane " + std::to_string(p);
      EXPECT_NEAR(r.whole_ml * 1000.0, whole, 1e-6 * whole) << where;
      EXPECT_NEAR(front, split, 1e-9 * whole) << where;
      EXPECT_NEAR(back, whole - split, 1e-9 * whole) << where;
      // Counting centres errs by up to half of each voxel the plane passes through (all the same
      // way for a plane parallel to the voxels' faces, half way between centre and face).
      EXPECT_LE(std::abs(front - count.front_mm3), 0.5 * clipped.straddling_mm3) << where;
      EXPECT_LE(std::abs(back - count.back_mm3), 0.5 * clipped.straddling_mm3) << where;
      std::printf(
          "%s: partial-voxel volumes against the centre count: front %+.2f%%, back %+.2f%%\n",
          where.c_str(), 100.0 * (front / count.front_mm3 - 1.0),
          100.0 * (back / count.back_mm3 - 1.0));
      // The parts written count the voxel centres.
      int64_t in_front = 0;
      for (int64_t k = 0; k < f.size[2]; ++k)
        for (int64_t j = 0; j < f.size[1]; ++j)
          for (int64_t i = 0; i < f.size[0]; ++i) {
            const int32_t l = plan.parts.labels[static_cast<size_t>(f.index(i, j, k))];
            in_front += l == (r.remnant_in_front ? 1 : 2);
          }
      EXPECT_NEAR(static_cast<double>(in_front) * f.voxel_volume_mm3(), count.front_mm3,
                  0.5 * f.voxel_volume_mm3())
          << where;
    }
  }
}

TEST(PlanResection, MarginsMatchADistanceMapOfTheTumour) {
  // The least distance map value of the tumour labels over the plane, sampled finely, against
  // the margin reported, for planes at several distances and angles from the right lobe's tumour.
  const LabelVolume v = carved_phantom();
  Mask tumour;
  tumour.frame = v.frame;
  tumour.inside.resize(v.labels.size());
  for (size_t i = 0; i < v.labels.size(); ++i) tumour.inside[i] = v.labels[i] == kPhantomTumour;
  const DistanceField map = signed_distance(tumour);
  const GridFrame& f = v.frame;
  // Trilinear sample of the map at physical point p (identity direction).
  const auto sample = [&](const Eigen::Vector3d& p) {
    double t[3];
    int64_t i0[3];
    for (int a = 0; a < 3; ++a) {
      const double x = (p[a] - f.origin_mm[a]) / f.spacing_mm[a];
      i0[a] = std::clamp<int64_t>(static_cast<int64_t>(std::floor(x)), 0, f.size[a] - 2);
      t[a] = std::clamp(x - static_cast<double>(i0[a]), 0.0, 1.0);
    }
    double s = 0.0;
    for (int c = 0; c < 8; ++c) {
      const int64_t di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
      const double w = (di ? t[0] : 1 - t[0]) * (dj ? t[1] : 1 - t[1]) * (dk ? t[2] : 1 - t[2]);
      s += w * map.phi[static_cast<size_t>(f.index(i0[0] + di, i0[1] + dj, i0[2] + dk))];
    }
    return s;
  };
  const Eigen::Vector3d centre(-60, -18, 32);
  const Eigen::Vector3d normals[] = {{1, 0, 0}, {0, 1, 1}, {-0.4, 0.2, 0.9}};
  for (const Eigen::Vector3d& n0 : normals)
    for (const double gap : {5.0, 12.0, 20.0}) {
      const Eigen::Vector3d n = n0.normalized();
      const Eigen::Vector3d point = centre + (15.0 + gap) * n;
      const ResectionPlan plan =
          plan_resection(v, SideOf(plane_surface(point, n)), carved_options());
      const TumourMargin& t = plan.report.tumours[0];
      ASSERT_NEAR(t.centre_mm.x(), -60.0, 0.5);
      // The plane's points near the tumour, every 0.25 mm.
      Eigen::Vector3d u = n.cross(Eigen::Vector3d::UnitX());
      if (u.norm() < 0.1) u = n.cross(Eigen::Vector3d::UnitY());
      u.normalize();
      const Eigen::Vector3d w = n.cross(u);
      const Eigen::Vector3d foot = centre + (point - centre).dot(n) * n;
      double least = INFINITY;
      for (double a = -20; a <= 20; a += 0.25)
        for (double b = -20; b <= 20; b += 0.25)
          least = std::min(least, sample(foot + a * u + b * w));
      EXPECT_NEAR(t.margin_mm, least, diagonal(f)) << "normal " << n.transpose() << " gap " << gap;
      EXPECT_NEAR(t.margin_mm, gap, diagonal(f));  // and the sphere's own
    }
}

TEST(PlanResection, ACurvedSurfaceDividesTheOrganLikeItsAnalyticShape) {
  // A triangulated sphere of radius 50 mm inside the phantom: its outside is its front. The
  // voxels whose centres lie outside the exact sphere are the reference (the triangles lie
  // inside it by at most 0.3 mm at this resolution).
  PhantomOptions po;
  po.anatomy = true;
  const LabelVolume v = make_phantom(po);
  const Eigen::Vector3d c(-40, 0, 0);
  const double radius = 50.0;
  const int rings = 60, segments = 120;
  Eigen::MatrixX3d V((rings - 1) * segments + 2, 3);
  std::vector<Eigen::Vector3i> tris;
  V.row(0) = (c + Eigen::Vector3d(0, 0, radius)).transpose();
  V.row(1) = (c - Eigen::Vector3d(0, 0, radius)).transpose();
  const auto at = [&](int ring, int s) { return 2 + (ring - 1) * segments + (s % segments); };
  for (int ring = 1; ring < rings; ++ring)
    for (int s = 0; s < segments; ++s) {
      const double th = std::numbers::pi * ring / rings, ph = 2 * std::numbers::pi * s / segments;
      V.row(at(ring, s)) = (c + radius * Eigen::Vector3d(std::sin(th) * std::cos(ph),
                                                         std::sin(th) * std::sin(ph), std::cos(th)))
                               .transpose();
    }
  for (int s = 0; s < segments; ++s) {
    tris.emplace_back(0, at(1, s), at(1, s + 1));
    tris.emplace_back(1, at(rings - 1, s + 1), at(rings - 1, s));
    for (int ring = 1; ring < rings - 1; ++ring) {
      tris.emplace_back(at(ring, s), at(ring + 1, s), at(ring + 1, s + 1));
      tris.emplace_back(at(ring, s), at(ring + 1, s + 1), at(ring, s + 1));
    }
  }
  Eigen::MatrixX3i F(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t) F.row(static_cast<Eigen::Index>(t)) = tris[t];
  const ResectionPlan plan =
      plan_resection(v, SideOf(mesh_surface(V, F, "sphere")), ResectionOptions{});
  double outside = 0.0, inside = 0.0;
  const GridFrame& f = v.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        if (v.labels[static_cast<size_t>(f.index(i, j, k))] == 0) continue;
        const auto p =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        ((Eigen::Vector3d(p[0], p[1], p[2]) - c).norm() > radius ? outside : inside) +=
            f.voxel_volume_mm3();
      }
  const ResectionReport& r = plan.report;
  EXPECT_TRUE(r.remnant_in_front);  // outside the sphere is the larger part
  EXPECT_NEAR(r.remnant_ml * 1000.0, outside, 0.01 * outside);
  EXPECT_NEAR(r.resected_ml * 1000.0, inside, 0.01 * inside);
}

TEST(PlanResection, RefusesASurfaceThatMissesTheOrganAndAbsentLabels) {
  const LabelVolume v = carved_phantom();
  const auto message = [&](const ResectionSurface& s, const ResectionOptions& o) -> std::string {
    try {
      plan_resection(v, SideOf(s), o);
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(message(plane_surface({0, 0, 300}, {0, 0, 1}), carved_options()).find("misses"),
            std::string::npos);
  ResectionOptions absent = carved_options();
  absent.structures.push_back({9, "bile_ducts", SurfaceRole::kVessel});
  EXPECT_NE(message(plane_surface({0, 0, 0}, {1, 0, 0}), absent).find("label 9"),
            std::string::npos);
  ResectionOptions on_plane = carved_options();
  on_plane.keep_point = Eigen::Vector3d(0, 5, 5);
  EXPECT_NE(message(plane_surface({0, 0, 0}, {1, 0, 0}), on_plane).find("lies on"),
            std::string::npos);
  EXPECT_THROW(plane_surface({0, 0, 0}, {0, 0, 0}), Error);
  EXPECT_THROW(closed_curve_surface({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, "curve"), Error);
  EXPECT_THROW(closed_curve_surface({{0, 0, 0}, {1, 1, 1}}, "curve"), Error);
}

TEST(PlanResection, IsTheSameOnOneThreadAsOnTwo) {
  // Threads share the voxel pass; the sums are added in the grid's order all the same.
  const LabelVolume v = carved_phantom();
  const SideOf side(plane_surface({25, 3, 0}, {1, 0.3, 0.2}));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const ResectionReport one = plan_resection(v, side, carved_options()).report;
  omp_set_num_threads(2);
  const ResectionReport two = plan_resection(v, side, carved_options()).report;
  omp_set_num_threads(threads);
  EXPECT_EQ(one.remnant_ml, two.remnant_ml);
  EXPECT_EQ(one.resected_ml, two.resected_ml);
  ASSERT_EQ(one.crossings.size(), two.crossings.size());
  ASSERT_FALSE(one.crossings.empty());
  for (size_t c = 0; c < one.crossings.size(); ++c) {
    EXPECT_EQ(one.crossings[c].area_mm2, two.crossings[c].area_mm2);
    EXPECT_EQ(one.crossings[c].position_mm, two.crossings[c].position_mm);
  }
}

TEST(PlanResection, AClosedCurveSpansTheSurfaceItsTurnFaces) {
  // A square curve in the plane x = 30, anticlockwise about +x: the same plan as the plane.
  const LabelVolume v = carved_phantom();
  const ResectionSurface curve = closed_curve_surface(
      {{30, -200, -200}, {30, 200, -200}, {30, 200, 200}, {30, -200, 200}}, "curve");
  const ResectionPlan a = plan_resection(v, SideOf(curve), carved_options());
  const ResectionPlan b =
      plan_resection(v, SideOf(plane_surface({30, 0, 0}, {1, 0, 0})), carved_options());
  EXPECT_EQ(a.report.remnant_in_front, b.report.remnant_in_front);
  EXPECT_NEAR(a.report.remnant_ml, b.report.remnant_ml, 1e-6);
  EXPECT_EQ(a.report.crossings.size(), b.report.crossings.size());
}

}  // namespace
}  // namespace lamina::geometry
