// Masks and models: read a segmentation, build, load and save a model, and look at it as numpy
// arrays (views of the model's own memory, read-only: a model is shared by its simulations).
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.h"
#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/build_model.h"
#include "lamina/model/summarize_model.h"

namespace py = pybind11;

namespace lamina::python {
namespace {

// A read-only numpy view of `data` (rows x cols, strides in bytes) kept alive by `owner`.
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides,
               py::handle owner) {
  py::array a(py::dtype::of<T>(), std::move(shape), std::move(strides), data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// An Eigen column-major matrix (rows x 3 or 4) as an (rows, cols) view.
template <class M>
py::array matrix_view(const M& x, py::handle owner) {
  using T = typename M::Scalar;
  const auto s = static_cast<py::ssize_t>(sizeof(T));
  return view(x.data(), {x.rows(), x.cols()}, {s, s * x.rows()}, owner);
}

template <class T>
py::array vector_view(const std::vector<T>& v, py::handle owner) {
  return view(v.data(), {static_cast<py::ssize_t>(v.size())}, {sizeof(T)}, owner);
}

ProgressFn python_progress(const py::object& callback) {
  if (callback.is_none()) return {};
  return [callback](std::string_view stage, double fraction) {
    py::gil_scoped_acquire gil;
    callback(std::string(stage), fraction);
  };
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
      "phantom", [] { return geometry::make_phantom(); }, "The built-in liver-like phantom mask.");

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
         double stiffness_n_per_m, int label, py::object progress) {
        model::BuildOptions o;
        o.layers = layers;
        o.skin_vertices = skin_vertices;
        o.locality = locality;
        o.density_kg_per_mm3 = density_kg_per_mm3;
        o.stiffness_n_per_m = stiffness_n_per_m;
        o.label = label;
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
      py::arg("label") = 0, py::arg("progress") = py::none(),
      "Builds a multi-layer model from a Mask or a path ('phantom' = the built-in one).\n"
      "layers: S (skin + S-1 inner layers); skin_vertices: target skin node count;\n"
      "locality: N, BFS rings per node; label: 0 = any non-zero voxel.\n"
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
