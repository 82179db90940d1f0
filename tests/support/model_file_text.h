#pragma once
// What the model file tests share (io::save_model, io::load_model): bit-for-bit comparison of
// two models, the file's text and its arrays edited in place, and the one-line refusal a
// corrupt file must get.

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/io/model_file.h"

namespace lamina::test {

inline uint64_t bits(double x) {
  return std::bit_cast<uint64_t>(x);
}

inline void expect_bitwise_equal(const std::vector<double>& a, const std::vector<double>& b,
                                 const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t k = 0; k < a.size(); ++k)
    EXPECT_EQ(bits(a[k]), bits(b[k])) << what << "[" << k << "]";
}

inline void expect_same_model(const Model& a, const Model& b) {
  ASSERT_EQ(a.X.rows(), b.X.rows());
  for (Eigen::Index v = 0; v < a.X.rows(); ++v)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(bits(a.X(v, c)), bits(b.X(v, c))) << v << "," << c;
  expect_bitwise_equal(a.mass_kg, b.mass_kg, "mass_kg");
  EXPECT_EQ(a.layer_of, b.layer_of);
  EXPECT_EQ(a.fixed, b.fixed);
  ASSERT_EQ(a.layer_count(), b.layer_count());
  for (int32_t l = 0; l < a.layer_count(); ++l) {
    EXPECT_EQ(a.layers[l].first_node, b.layers[l].first_node);
    EXPECT_EQ(a.layers[l].node_count, b.layers[l].node_count);
    EXPECT_EQ(a.layers[l].F, b.layers[l].F) << "layer " << l;
  }
  EXPECT_EQ(a.springs.i, b.springs.i);
  EXPECT_EQ(a.springs.j, b.springs.j);
  expect_bitwise_equal(a.springs.rest_length_mm, b.springs.rest_length_mm, "rest_length_mm");
  expect_bitwise_equal(a.springs.stiffness_n_per_m, b.springs.stiffness_n_per_m, "stiffness");
  EXPECT_EQ(a.springs.kind, b.springs.kind);
  EXPECT_EQ(bits(a.density_kg_per_mm3), bits(b.density_kg_per_mm3));
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.rings.locality, b.rings.locality);
  EXPECT_EQ(a.tets.T, b.tets.T);
  EXPECT_EQ(a.tets.region, b.tets.region);
  // A cut model's shares and materials (an uncut one's are all 1 and 15).
  for (size_t e = 0; e < a.springs.size() && e < b.springs.size(); ++e)
    EXPECT_EQ(bits(a.springs.share_of(e)), bits(b.springs.share_of(e))) << "spring " << e;
  for (int64_t t = 0; t < a.tets.size() && t < b.tets.size(); ++t) {
    EXPECT_EQ(bits(a.tets.share_of(t)), bits(b.tets.share_of(t))) << "tetrahedron " << t;
    EXPECT_EQ(a.tets.material_of(t), b.tets.material_of(t)) << "tetrahedron " << t;
  }
  ASSERT_EQ(a.embedded.size(), b.embedded.size());
  for (size_t s = 0; s < a.embedded.size(); ++s) {
    const EmbeddedSurface &e = a.embedded[s], &f = b.embedded[s];
    EXPECT_EQ(e.name, f.name) << "surface " << s;
    EXPECT_EQ(e.label, f.label) << e.name;
    EXPECT_EQ(e.role, f.role) << e.name;
    EXPECT_EQ(e.outside, f.outside) << e.name;
    EXPECT_EQ(e.F, f.F) << e.name;
    EXPECT_EQ(e.corners, f.corners) << e.name;
    const auto as_vector = [](const auto& matrix) {
      return std::vector<double>(matrix.data(), matrix.data() + matrix.size());
    };
    ASSERT_EQ(e.V.rows(), f.V.rows()) << e.name;
    ASSERT_EQ(e.weights.rows(), f.weights.rows()) << e.name;
    expect_bitwise_equal(as_vector(e.V), as_vector(f.V), "embedded V");
    expect_bitwise_equal(as_vector(e.weights), as_vector(f.weights), "embedded weights");
    ASSERT_EQ(e.offsets.rows(), f.offsets.rows()) << e.name;
    expect_bitwise_equal(as_vector(e.offsets), as_vector(f.offsets), "embedded offsets");
  }
  ASSERT_EQ(a.trees.size(), b.trees.size());
  for (size_t t = 0; t < a.trees.size(); ++t) {
    const ModelVesselTree &e = a.trees[t], &f = b.trees[t];
    EXPECT_EQ(e.flow.name, f.flow.name);
    EXPECT_EQ(e.flow.kind, f.flow.kind);
    EXPECT_EQ(e.label, f.label);
    EXPECT_EQ(e.flow.roots, f.flow.roots);
    EXPECT_EQ(e.flow.seed_upstream, f.flow.seed_upstream);
    EXPECT_EQ(e.flow.seed_branch, f.flow.seed_branch);
    EXPECT_EQ(e.flow.branch_parent, f.flow.branch_parent);
    EXPECT_EQ(e.flow.branch_rooted, f.flow.branch_rooted);
    expect_bitwise_equal(e.flow.branch_length_mm, f.flow.branch_length_mm, "branch length");
    expect_bitwise_equal(e.flow.branch_radius_mm, f.flow.branch_radius_mm, "branch radius");
    expect_bitwise_equal(e.flow.branch_territory_ml, f.flow.branch_territory_ml, "territory");
    EXPECT_EQ(e.in_organ, f.in_organ);
    EXPECT_EQ(e.seeds.corners, f.seeds.corners);
    EXPECT_EQ(e.seeds.V, f.seeds.V);
    EXPECT_EQ(e.seeds.weights, f.seeds.weights);
    EXPECT_EQ(e.seeds.offsets, f.seeds.offsets);
  }
}

inline std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Replaces the values of the array named `name` with `values`.
inline std::string replace_values(std::string text, const std::string& name,
                                  const std::string& values) {
  const size_t at = text.find("Name=\"" + name + "\"");
  EXPECT_NE(at, std::string::npos) << name;
  const size_t begin = text.find('>', at) + 1, end = text.find('<', begin);
  return text.replace(begin, end - begin, values);
}

// Runs load_model(path) and checks that it fails the way the API promises: kInvalidInput, one
// line, naming the file, and mentioning `expected`.
inline void expect_load_error(const std::string& path, const std::string& expected) {
  try {
    io::load_model(path);
    ADD_FAILURE() << "load_model accepted " << path << " (expected: " << expected << ")";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << message;
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

/// Corruptions of a model, each with the words its refusal must contain.
using ModelCorruptions = std::vector<std::pair<std::function<void(Model&)>, std::string>>;

// For models that save_model() writes as they are but load_model() must refuse: saves each
// corruption of make() to `path` and expects its refusal.
inline void expect_each_refused_on_load(const std::string& path, const std::function<Model()>& make,
                                        const ModelCorruptions& cases) {
  for (const auto& [corrupt, expected] : cases) {
    Model model = make();
    corrupt(model);
    io::save_model(model, path);
    expect_load_error(path, expected);
  }
}

}  // namespace lamina::test
