// Masks and models: read a segmentation, build, load and save a model, and look at it as numpy
// arrays (views of the model's own memory, read-only: a model is shared by its simulations).
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <variant>

#include "bindings.h"
#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/summarize_model.h"

namespace py = pybind11;

namespace lamina::python {
namespace {

template <class T>
py::array vector_view(const std::vector<T>& v, py::handle owner) {
  return view(v.data(), {static_cast<py::ssize_t>(v.size())}, {sizeof(T)}, owner);
}

// A getter for a matrix member of a bound type T: a read-only view that keeps `self` alive.
template <class T, class M>
auto field_view(M T::*field) {
  return [field](py::object self) { return matrix_view(self.cast<const T&>().*field, self); };
}

ProgressFn python_progress(const py::object& callback) {
  if (callback.is_none()) return {};
  return [callback](std::string_view stage, double fraction) {
    py::gil_scoped_acquire gil;
    callback(std::string(stage), fraction);
  };
}

// A Mask (copied: the build shares it) or a path read as read_mask reads it.
std::shared_ptr<const LabelVolume> mask_of(const py::handle& what) {
  if (py::isinstance<py::str>(what))
    return std::make_shared<const LabelVolume>(io::read_input(what.cast<std::string>()));
  return std::make_shared<const LabelVolume>(what.cast<const LabelVolume&>());
}

// build_model's `embed` entries, as `lamina build --embed` / `--embed-mask` take them: a label
// of the same segmentation (an int, or (label, name[, role])), a separate mask ((Mask or path,
// name[, role])), or a dict with `label`, `name`, `mask` and `role` (each optional but one of
// label and mask). Without a role, the one its name suggests.
model::EmbedStructure embed_structure(const py::handle& entry, size_t k) {
  const std::string what = "build_model: embed[" + std::to_string(k) + "]";
  const auto refuse = [&]() -> model::EmbedStructure {
    throw invalid_input(what, "is " + py::repr(entry).cast<std::string>() +
                                  "; a label, (label, name[, role]), (Mask or path, name[, role]) "
                                  "or a dict with label, name, mask, role expected");
  };
  model::EmbedStructure s;
  py::object mask = py::none();
  if (py::isinstance<py::int_>(entry) && !py::isinstance<py::bool_>(entry)) {
    s.label = entry.cast<int32_t>();
  } else if (py::isinstance<py::tuple>(entry) || py::isinstance<py::list>(entry)) {
    const auto t = py::reinterpret_borrow<py::sequence>(entry);
    if (t.size() < 2 || t.size() > 3 || !py::isinstance<py::str>(t[1])) return refuse();
    s.name = t[1].cast<std::string>();
    if (t.size() == 3) {
      if (!py::isinstance<py::str>(t[2])) return refuse();
      s.role = structure_role_of(t[2].cast<std::string>(), what);
    }
    if (py::isinstance<py::int_>(t[0]) && !py::isinstance<py::bool_>(t[0]))
      s.label = t[0].cast<int32_t>();
    else if (py::isinstance<py::str>(t[0]) || py::isinstance<LabelVolume>(t[0]))
      mask = t[0];
    else
      return refuse();
  } else if (py::isinstance<py::dict>(entry)) {
    const auto d = py::reinterpret_borrow<py::dict>(entry);
    for (const auto& [key, value] : d) {
      const std::string name = py::str(key);
      if (name == "label")
        s.label = value.cast<int32_t>();
      else if (name == "name")
        s.name = value.cast<std::string>();
      else if (name == "mask")
        mask = py::reinterpret_borrow<py::object>(value);
      else if (name == "role")
        s.role = structure_role_of(value.cast<std::string>(), what);
      else
        throw invalid_input(what, "has key '" + name + "'; label, name, mask and role expected");
    }
    if (mask.is_none() && s.label == 0) return refuse();
  } else {
    return refuse();
  }
  if (!mask.is_none()) s.mask = mask_of(mask);  // unnamed: named after its file, as the CLI's
  return s;
}

}  // namespace

void bind_model(py::module_& m) {
  py::class_<LabelVolume>(m, "Mask",
                          "A segmentation in physical space: labels (k, j, i order), mm frame")
      .def_property_readonly(
          "shape",
          [](const LabelVolume& v) {
            return py::make_tuple(v.frame.size[2], v.frame.size[1], v.frame.size[0]);
          },
          "(k, j, i) voxels, numpy order")
      .def_property_readonly(
          "spacing_mm", [](const LabelVolume& v) { return v.frame.spacing_mm; },
          "voxel size along i, j, k, mm")
      .def_property_readonly(
          "origin_mm", [](const LabelVolume& v) { return v.frame.origin_mm; },
          "centre of voxel (0, 0, 0), mm (LPS)")
      .def_property_readonly(
          "direction", [](const LabelVolume& v) { return v.frame.direction; },
          "row-major 3x3: column c is the direction of index axis c")
      .def_property_readonly(
          "labels",
          [](py::object self) {
            const auto& v = self.cast<const LabelVolume&>();
            const auto s = static_cast<py::ssize_t>(sizeof(int32_t));
            const auto& n = v.frame.size;
            return view(v.labels.data(), {n[2], n[1], n[0]}, {s * n[0] * n[1], s * n[0], s}, self);
          },
          "int32 array (k, j, i), a read-only view")
      .def_readonly("source", &LabelVolume::source)
      .def("__repr__", [](const LabelVolume& v) {
        return "<lamina.Mask " + v.source + " " + std::to_string(v.frame.size[0]) + "x" +
               std::to_string(v.frame.size[1]) + "x" + std::to_string(v.frame.size[2]) + ">";
      });

  m.def(
      "read_mask", [](const std::string& path) { return io::read_input(path); }, py::arg("path"),
      "Reads a segmentation: NIfTI, NRRD, MetaImage, a DICOM folder, or 'phantom'.\n"
      "Headers are checked (docs/errors.md); raises lamina.Error naming the file and field.");
  m.def(
      "phantom",
      [](const std::variant<double, std::array<double, 3>>& spacing_mm, bool anatomy,
         bool carved_out, bool wrapped) {
        geometry::PhantomOptions o;
        if (const double* s = std::get_if<double>(&spacing_mm))
          o.spacing_mm = {*s, *s, *s};
        else
          o.spacing_mm = std::get<std::array<double, 3>>(spacing_mm);
        o.anatomy = anatomy;
        o.carved_out = carved_out;
        o.wrapped = wrapped;
        return geometry::make_phantom(o);
      },
      py::kw_only(), py::arg("spacing_mm") = 1.5, py::arg("anatomy") = false,
      py::arg("carved_out") = false, py::arg("wrapped") = false,
      "The built-in liver-like phantom mask. spacing_mm: voxel size, one value or (i, j, k);\n"
      "anatomy: labels 1 liver, 2 a vessel tree, 3 a tumour (lamina phantom --labels), the\n"
      "organ their union; carved_out: the anatomy as most labelmaps store it (lamina phantom\n"
      "--carved-out): 1 parenchyma only, 2 portal vein (its trunk beyond the organ), 3 tumours,\n"
      "4 hepatic veins, 5 inferior vena cava; build it with label=1 and embed; else label 1.\n"
      "wrapped: the vena cava wrapped by the liver (lamina phantom --wrapped): with carved_out,\n"
      "the vena cava and the veins draining into it are tunnels through label 1.");

  py::class_<EmbeddedSurface>(
      m, "EmbeddedSurface",
      "A surface carried by the model's tetrahedra (the display skin, a structure inside the\n"
      "organ): vertex v lies at sum_c weights[v, c] * x[corners[v, c]] + offsets[v]. Arrays\n"
      "are read-only views of the model's memory.")
      .def_readonly("name", &EmbeddedSurface::name, "'display_skin', or the structure's name")
      .def_property_readonly(
          "role", [](const EmbeddedSurface& e) { return std::string(role_name(e.role)); },
          "what it is: 'display_skin', 'vessel', 'tumour', 'structure' or 'wound'")
      .def_readonly("label", &EmbeddedSurface::label,
                    "the segmentation label it came from (0: the organ's own skin)")
      .def_readonly("outside", &EmbeddedSurface::outside,
                    "vertices in no tetrahedron at rest (they follow the nearest)")
      .def_property_readonly("V", field_view(&EmbeddedSurface::V),
                             "rest positions, (vertices, 3) float64, mm")
      .def_property_readonly("F", field_view(&EmbeddedSurface::F),
                             "triangles, (faces, 3) int32 rows of V, outward")
      .def_property_readonly("corners", field_view(&EmbeddedSurface::corners),
                             "each vertex's tetrahedron, (vertices, 4) int32 node indices")
      .def_property_readonly(
          "weights", field_view(&EmbeddedSurface::weights),
          "barycentric weights of the corners, (vertices, 4) float64, summing to 1")
      .def_property_readonly(
          "offsets",
          [](const EmbeddedSurface& e) -> py::array_t<double> {
            // Stored only when some vertex has one; zeros otherwise, so W x + offsets always works.
            py::array_t<double> out({static_cast<py::ssize_t>(e.V.rows()), py::ssize_t{3}});
            auto o = out.mutable_unchecked<2>();
            for (Eigen::Index v = 0; v < e.V.rows(); ++v)
              for (int c = 0; c < 3; ++c) o(v, c) = e.offsets.rows() > 0 ? e.offsets(v, c) : 0.0;
            return out;
          },
          "rest-space offsets added to W x, (vertices, 3) float64, mm: zero but for vertices\n"
          "far outside the tetrahedra (a vessel's trunk beyond the organ), which follow them by\n"
          "translation (a copy)")
      .def_property_readonly("max_amplification", &model::max_amplification,
                             "the largest sum of |weights|: no vertex moves more than this many\n"
                             "times its tetrahedron's largest node motion (at most 2)")
      .def("__repr__", [](const EmbeddedSurface& e) {
        return "<lamina.EmbeddedSurface '" + e.name + "' (" + std::string(role_name(e.role)) +
               ") label " + std::to_string(e.label) + ", " + std::to_string(e.V.rows()) +
               " vertices, " + std::to_string(e.F.rows()) + " triangles>";
      });

  py::class_<Model, std::shared_ptr<Model>>(m, "Model",
                                            "A multi-layer mass-spring model (mm, kg). Arrays are "
                                            "read-only views of the model's memory.")
      .def_property_readonly("node_count", &Model::node_count)
      .def_property_readonly("layer_count", &Model::layer_count)
      .def_property_readonly(
          "skin_node_count",
          [](const Model& m) { return m.layers.empty() ? 0 : m.layers[0].node_count; },
          "nodes 0 .. skin_node_count-1 are the skin (layer 0)")
      .def_property_readonly(
          "X", [](py::object self) { return matrix_view(self.cast<const Model&>().X, self); },
          "rest positions, (nodes, 3) float64, mm")
      .def_property_readonly(
          "mass_kg",
          [](py::object self) { return vector_view(self.cast<const Model&>().mass_kg, self); },
          "lumped node masses, (nodes,) kg")
      .def_property_readonly(
          "layer_of",
          [](py::object self) { return vector_view(self.cast<const Model&>().layer_of, self); },
          "layer of each node, (nodes,) int32; -1 = interior")
      .def(
          "triangles",
          [](py::object self, int layer) {
            const Model& mo = self.cast<const Model&>();
            if (layer < 0 || layer >= mo.layer_count())
              throw invalid_input("Model.triangles: layer",
                                  "is " + std::to_string(layer) + "; 0.." +
                                      std::to_string(mo.layer_count() - 1) + " expected");
            return matrix_view(mo.layers[layer].F, self);
          },
          py::arg("layer") = 0,
          "a layer's triangles, (faces, 3) int32 global node indices, outward")
      .def_property_readonly(
          "springs",
          [](py::object self) {
            const Springs& s = self.cast<const Model&>().springs;
            return py::make_tuple(vector_view(s.i, self), vector_view(s.j, self),
                                  vector_view(s.rest_length_mm, self),
                                  vector_view(s.stiffness_n_per_m, self));
          },
          "(i, j, rest_length_mm, stiffness_n_per_m) arrays, one entry per spring")
      .def_property_readonly(
          "tets",
          [](py::object self) { return matrix_view(self.cast<const Model&>().tets.T, self); },
          "tetrahedra, (tets, 4) int32 node indices, positively oriented at rest")
      .def_property_readonly(
          "embedded",
          [](py::object self) {
            // References into the model, each keeping it alive (its arrays are views).
            py::list out;
            for (const EmbeddedSurface& e : self.cast<const Model&>().embedded)
              out.append(py::cast(&e, py::return_value_policy::reference_internal, self));
            return out;
          },
          "surfaces carried by the tetrahedra: a list of EmbeddedSurface, the display skin\n"
          "('display_skin') first when built, then the structures (build_model's embed)")
      .def_readonly("source", &Model::source)
      .def(
          "summary",
          [](const Model& mo) {
            return py::module_::import("json").attr("loads")(
                io::summary_json(model::summarize_model(mo), nullptr, mo.source));
          },
          "what `lamina info --json` prints: layers, springs, tetrahedra, quality, mass")
      .def(
          "save", [](const Model& mo, const std::string& path) { io::save_model(mo, path); },
          py::arg("path"), "Saves as VTK XML (.vtu); written whole or not at all.")
      .def("__repr__", [](const Model& mo) {
        return "<lamina.Model " + std::to_string(mo.node_count()) + " nodes, " +
               std::to_string(mo.layer_count()) + " layers, " + std::to_string(mo.springs.size()) +
               " springs, " + std::to_string(mo.tets.size()) + " tets>";
      });

  m.def(
      "build_model",
      [](py::object input, int layers, int skin_vertices, int locality, double density_kg_per_mm3,
         double stiffness_n_per_m, int label, const std::vector<int32_t>& labels,
         int64_t display_triangles, const py::sequence& embed, int64_t structure_triangles,
         py::object progress) {
        if (label != 0 && !labels.empty())
          throw invalid_input(
              "build_model: label",
              "is " + std::to_string(label) + " with labels also given; give one of them");
        model::BuildOptions o;
        o.layers = layers;
        o.skin_vertices = skin_vertices;
        o.locality = locality;
        o.density_kg_per_mm3 = density_kg_per_mm3;
        o.stiffness_n_per_m = stiffness_n_per_m;
        o.label = label;
        o.labels = labels;
        o.display_triangles = display_triangles;
        o.structure_triangles = structure_triangles;
        for (size_t k = 0; k < embed.size(); ++k) o.embed.push_back(embed_structure(embed[k], k));
        const LabelVolume volume = py::isinstance<py::str>(input)
                                       ? io::read_input(input.cast<std::string>())
                                       : input.cast<LabelVolume>();
        const ProgressFn fn = python_progress(progress);
        py::gil_scoped_release release;
        return std::make_shared<Model>(model::build_model(volume, o, fn).model);
      },
      py::arg("mask") = "phantom", py::kw_only(), py::arg("layers") = 2,
      py::arg("skin_vertices") = 1284, py::arg("locality") = 4,
      py::arg("density_kg_per_mm3") = 1.06e-6, py::arg("stiffness_n_per_m") = 3.0,
      py::arg("label") = 0, py::arg("labels") = std::vector<int32_t>{},
      py::arg("display_triangles") = 100000, py::arg("embed") = py::list(),
      py::arg("structure_triangles") = 20000, py::arg("progress") = py::none(),
      "Builds a multi-layer model from a Mask or a path ('phantom' = the built-in one).\n"
      "layers: S (skin + S-1 inner layers); skin_vertices: target skin node count;\n"
      "locality: N, BFS rings per node; label: 0 = any non-zero voxel; labels: the organ is\n"
      "the union of these (instead of label).\n"
      "display_triangles: the display skin's triangles (capped at the mask's resolution;\n"
      "0 = none). embed: structures carried inside the organ, each a label of the same mask\n"
      "(2 or (2, 'vessels')), a separate mask on its grid ((Mask or path, 'tumour')), or a\n"
      "dict with label, name, mask; structure_triangles: each one's triangle budget.\n"
      "They are Model.embedded.\n"
      "progress: callable(stage: str, fraction: float), or None.");
  m.def(
      "load_model",
      [](const std::string& path, int locality) {
        // A saved model only: scene_for() would take any other path for a mask and build from it.
        io::Scene scene;
        scene.input.clear();
        scene.model_path = path;
        scene.routing.locality = locality;
        return std::make_shared<Model>(io::make_scene_model(scene).model);
      },
      py::arg("path"), py::kw_only(), py::arg("locality") = 4,
      "Loads a saved model (.vtu) with rings up to `locality`.");
}

}  // namespace lamina::python
