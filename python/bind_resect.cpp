// Resection planning: lamina.resect(), the report of `lamina resect --json` as a dict and the
// parts as a numpy array (docs/resection.md).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <array>
#include <optional>
#include <variant>

#include "bindings.h"
#include "lamina/core/error.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/io/model_file.h"
#include "lamina/io/resection_input.h"
#include "lamina/io/resection_report.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/plan_on_model.h"

namespace py = pybind11;

namespace lamina::python {
namespace {

using Point = std::array<double, 3>;

Eigen::Vector3d vec(const Point& p) {
  return {p[0], p[1], p[2]};
}

// embed entries: 2, (2, "portal_vein") or (2, "portal_vein", "vessel"); named by label when
// unnamed, of the role its name suggests when none is given.
geometry::ResectionStructure structure_of(const py::handle& entry) {
  geometry::ResectionStructure s;
  std::optional<SurfaceRole> role;
  if (py::isinstance<py::int_>(entry)) {
    s.label = entry.cast<int32_t>();
    s.name = "label " + std::to_string(s.label);
  } else {
    const auto t = entry.cast<py::sequence>();
    if (t.size() < 2 || t.size() > 3)
      throw invalid_input("resect: embed",
                          "a structure is LABEL, (LABEL, NAME) or (LABEL, NAME, "
                          "ROLE)");
    s.label = t[0].cast<int32_t>();
    s.name = t[1].cast<std::string>();
    if (t.size() == 3) role = structure_role_of(t[2].cast<std::string>(), "resect: embed");
  }
  if (s.label <= 0) throw invalid_input("resect: embed", "a structure's label must be > 0");
  s.role = role.value_or(geometry::guess_role(s.name));
  return s;
}

}  // namespace

void bind_resect(py::module_& m) {
  m.def(
      "resect",
      [](py::object input, std::optional<std::pair<Point, Point>> plane,
         std::optional<std::string> surface, std::optional<Point> keep, double margin_mm,
         const std::string& liver, const std::vector<int32_t>& labels, const py::sequence& embed,
         const py::object& segments) {
        if (plane.has_value() == surface.has_value())
          throw invalid_input("resect", "give one of plane=(point, normal) or surface=PATH");
        geometry::ResectionOptions o;
        const bool phantom =
            py::isinstance<py::str>(input) && input.cast<std::string>() == io::kScenePhantom;
        if (phantom && labels.empty() && embed.size() == 0)
          o = geometry::planning_phantom_options();
        if (!labels.empty()) o.organ_labels = labels;
        for (const auto& e : embed) o.structures.push_back(structure_of(e));
        o.margin_mm = margin_mm;
        // segments: True (placed as `auto`), or what places them: "auto", "vessels", "atlas".
        if (py::isinstance<py::bool_>(segments)) {
          o.segments = segments.cast<bool>();
        } else if (py::isinstance<py::str>(segments)) {
          const std::string from = segments.cast<std::string>();
          o.segments = true;
          if (from == "vessels")
            o.segments_from = geometry::SegmentPlacement::kVessels;
          else if (from == "atlas")
            o.segments_from = geometry::SegmentPlacement::kAtlas;
          else if (from != "auto")
            throw invalid_input("resect",
                                "segments='" + from + "': say True, 'auto', 'vessels' or 'atlas'");
        } else {
          throw invalid_input("resect", "segments: say True, 'auto', 'vessels' or 'atlas'");
        }
        if (liver == "normal")
          o.liver = geometry::LiverCondition::kNormal;
        else if (liver == "chemotherapy")
          o.liver = geometry::LiverCondition::kChemotherapy;
        else if (liver == "cirrhosis")
          o.liver = geometry::LiverCondition::kCirrhosis;
        else
          throw invalid_input("resect: liver",
                              "'" + liver + "' is not normal, chemotherapy or cirrhosis");
        if (keep) o.keep_point = vec(*keep);
        const geometry::ResectionSurface s =
            plane ? geometry::plane_surface(vec(plane->first), vec(plane->second))
                  : io::read_resection_surface(*surface);
        auto plan = std::make_shared<geometry::ResectionPlan>();
        // A model (a Model, or a .vtu path): planned from its own surfaces, no parts.
        std::shared_ptr<const Model> model;
        if (py::isinstance<Model>(input)) model = input.cast<std::shared_ptr<Model>>();
        if (py::isinstance<py::str>(input) && input.cast<std::string>().ends_with(".vtu"))
          model = std::make_shared<Model>(io::load_model(input.cast<std::string>()));
        if (model) {
          if (!labels.empty() || embed.size() > 0)
            throw invalid_input("resect",
                                "a model's structures are its own: labels and embed "
                                "are for segmentations");
          py::gil_scoped_release release;
          plan->report = model::plan_on_model(*model, model->X, s, o);
        } else {
          const LabelVolume volume =
              phantom ? geometry::planning_phantom()
                      : (py::isinstance<py::str>(input) ? io::read_input(input.cast<std::string>())
                                                        : input.cast<LabelVolume>());
          py::gil_scoped_release release;
          const geometry::SideOf side(s);
          *plan = geometry::plan_resection(volume, side, o);
        }
        py::dict report = py::module_::import("json").attr("loads")(
            io::resection_report_json(plan->report, s, surface.value_or("")));
        // The parts as a (k, j, i) int32 array that owns a copy of them, and as a lamina.Mask.
        if (model) return report;
        py::object mask = py::cast(plan->parts);
        report["parts"] = mask.attr("labels").attr("copy")();
        report["parts_mask"] = mask;
        // The functional remnant's volumes, when assessed: each remnant voxel's function and
        // each tree's territories, by the tree's name.
        if (plan->report.functional) {
          report["function"] = py::cast(plan->function).attr("labels").attr("copy")();
          py::dict territories;
          for (size_t t = 0; t < plan->trees.size(); ++t)
            territories[py::str(plan->trees[t].territories.name)] =
                py::cast(plan->territories[t]).attr("labels").attr("copy")();
          report["territories"] = territories;
        }
        if (plan->report.segment_landmarks)
          report["segments"] = py::cast(plan->segments).attr("labels").attr("copy")();
        return report;
      },
      py::arg("mask") = "phantom", py::kw_only(), py::arg("plane") = py::none(),
      py::arg("surface") = py::none(), py::arg("keep") = py::none(), py::arg("margin_mm") = 10.0,
      py::arg("liver") = "normal", py::arg("labels") = std::vector<int32_t>{},
      py::arg("embed") = py::list(), py::arg("segments") = py::bool_(false),
      "Plans a resection (lamina resect): mask is a Mask or a path ('phantom' = the built-in\n"
      "one with its carved-out anatomy, already named), or a Model or .vtu path (planned from\n"
      "its own surfaces along a plane; no parts). plane=((x, y, z), (nx, ny, nz)) mm LPS,\n"
      "or surface=PATH (.mrk.json plane or closed curve, .obj, .ply, .stl, .off); keep: a point\n"
      "on the side kept (None: the larger); margin_mm: the margin wanted around tumours; liver:\n"
      "normal (20%), chemotherapy (30%) or cirrhosis (40%); labels: the organ's labels; embed:\n"
      "structures, 2 or (2, 'portal_vein') - a name saying tumour gets margins.\n"
      "Returns the report as a dict (the keys of `lamina resect --json`), with 'parts': int32\n"
      "(k, j, i), 1 remnant, 2 resected, and 'parts_mask': the same as a lamina.Mask; with a\n"
      "portal vein or hepatic veins among the structures also 'function' (int32 (k, j, i): 1\n"
      "functional, 2 devascularized, 3 congested, 4 both) and 'territories' ({tree name: int32\n"
      "(k, j, i) branch id + 1}); segments=True: Couinaud's segments ('segments': int32 (k, j, i)\n"
      "1-8: docs/resection.md), placed as `auto`; or segments='vessels' or 'atlas' (the\n"
      "organ alone suffices; lamina resect --segments-from).");
}

}  // namespace lamina::python
