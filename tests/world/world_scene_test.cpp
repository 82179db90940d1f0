// World scenes (io/world_scene.h) and organs from one segmentation (model/build_organs.h): a
// body is read as a scene is and its mistakes are named where they are; names and attachments
// are checked against each other; a world made from the TotalSegmentator example holds its
// organs where the CT has them, tied where they touch; overlapping masks give each voxel to
// one organ; a blade divides the ties it passes.
#include "lamina/io/world_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "lamina/core/error.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/model/build_organs.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

// The message parse_world_scene() refuses `text` with ("" if it does not).
std::string refusal(const std::string& text) {
  try {
    io::parse_world_scene(text, "w.json");
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    return e.what();
  }
  return "";
}

const std::string kTwo = R"({
  "bodies": [{"name": "a", "model": {"input": "phantom"}},
             {"name": "b", "model": {"input": "phantom"}, "tools": [{"vertex": 3, "force_n": [0, 0.1, 0]}]}],
  "attachments": [{"bodies": ["a", "b"], "strength_kpa": 12}],
  "contact": {"stiffness_kpa_per_mm": 40, "self_contact": false},
  "solver": {"integrator": "implicit_euler", "dt_s": 0.002},
  "output": {"frame_interval_s": 0.1}
})";

TEST(WorldScene, EachBodyIsReadAsASceneWithTheWorldsSolverAndNoDefaultPoke) {
  ASSERT_TRUE(io::is_world_scene(kTwo));
  EXPECT_FALSE(io::is_world_scene(R"({"model": {"input": "phantom"}})"));
  EXPECT_FALSE(io::is_world_scene("{ not json"));
  const io::WorldScene w = io::parse_world_scene(kTwo, "w.json");
  ASSERT_EQ(w.bodies.size(), 2u);
  EXPECT_EQ(w.bodies[0].name, "a");
  for (const io::WorldBodyScene& b : w.bodies) EXPECT_DOUBLE_EQ(b.scene.solver.dt_s, 0.002);
  EXPECT_DOUBLE_EQ(w.solver.dt_s, 0.002);
  EXPECT_DOUBLE_EQ(w.output.frame_interval_s, 0.1);
  EXPECT_FALSE(w.bodies[0].scene.default_tool);  // no "tools": none, not the paper's poke
  EXPECT_EQ(w.bodies[1].scene.tools.size(), 1u);
  ASSERT_EQ(w.attachments.size(), 1u);
  EXPECT_EQ(w.attachments[0].body_b, "b");
  EXPECT_DOUBLE_EQ(w.attachments[0].def.strength_kpa, 12.0);
  EXPECT_DOUBLE_EQ(w.contact.stiffness_kpa_per_mm, 40.0);
  EXPECT_FALSE(w.contact.self_contact);
}

TEST(WorldScene, MistakesAreNamedWhereTheyAre) {
  const auto has = [](const std::string& message, const std::string& part) {
    return message.find(part) != std::string::npos;
  };
  std::string m = refusal(R"({"bodies": [{"model": {"input": "phantom"}}]})");
  EXPECT_TRUE(has(m, "bodies[0]: needs \"name\"")) << m;
  m = refusal(R"({"bodies": [{"name": "a"}, {"name": "a"}]})");
  EXPECT_TRUE(has(m, "bodies[1].name: \"a\" names another body")) << m;
  m = refusal(R"({"bodies": [{"name": "a", "material": {"young_modulus_kpa": -1}}]})");
  EXPECT_TRUE(has(m, "w.json: bodies[0].material.young_modulus_kpa")) << m;
  m = refusal(R"({"bodies": [{"name": "a", "solver": {"dt_s": 0.01}}]})");
  EXPECT_TRUE(has(m, "bodies[0].solver: a world's bodies step together")) << m;
  m = refusal(R"({"bodies": [{"name": "a"}, {"name": "b"}],
                  "attachments": [{"bodies": ["a", "spleen"]}]})");
  EXPECT_TRUE(has(m, "attachments[0].bodies[1]: no body is named \"spleen\" (the bodies: a, b)"))
      << m;
  m = refusal(R"({"bodies": [{"name": "a"}], "attachments": [{"bodies": ["a", "a"]}]})");
  EXPECT_TRUE(has(m, "attached to itself")) << m;
  m = refusal(R"({"bodies": [{"name": "a", "tools": [{"scalpel": {"path": [[0,0,0],[1,0,0]],
                  "depth_mm": -5, "end_s": 1}}]}]})");
  EXPECT_TRUE(has(m, "bodies[0].tools[0].scalpel.depth_mm")) << m;
  m = refusal(R"({"bodies": [{"name": "a"}], "dissections": [{"depth_mm": 5}]})");
  EXPECT_TRUE(has(m, "dissections[0]: needs \"path\"")) << m;
  m = refusal(R"({"bodies": [{"name": "a"}], "contact": {"reach_mm": 0}})");
  EXPECT_TRUE(has(m, "contact.reach_mm: must be > 0")) << m;
  m = refusal(R"({"bodies": [], "solver": {"dt_s": 0.001}})");
  EXPECT_TRUE(has(m, "bodies: expected an array of bodies")) << m;
  m = refusal(R"({"bodies": [{"name": "a"}], "solver": {"dt_s": -1}})");
  EXPECT_TRUE(has(m, "w.json: solver.dt_s")) << m;
}

TEST(WorldScene, TwoBodiesInOnePlaceAreRefusedNamingBoth) {
  const io::WorldScene w = io::parse_world_scene(
      R"({"bodies": [{"name": "first", "model": {"input": "phantom", "build": {"skin_vertices": 300}}},
                     {"name": "second", "model": {"input": "phantom", "build": {"skin_vertices": 300}}}]})",
      "w.json");
  try {
    io::make_ready_world(w);
    FAIL() << "two phantoms in one place were made a world";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("w.json: bodies 'first' and 'second' overlap"), std::string::npos) << m;
  }
}

TEST(WorldScene, AWorldOfTheTotalSegmentatorOrgansTiesTheGallbladderToItsBed) {
  const std::string data = test::source_path("tests/data").string();
  const io::WorldScene w = io::parse_world_scene(
      R"({"bodies": [
        {"name": "liver", "model": {"input": ")" +
          data +
          R"(/liver_totalseg_example_3mm_labels.nii.gz", "build": {"label": 1, "display_triangles": 0}}},
        {"name": "gallbladder", "model": {"input": ")" +
          data +
          R"(/liver_totalseg_example_3mm_labels.nii.gz", "build": {"label": 4, "skin_vertices": 400, "display_triangles": 0}}}],
        "attachments": [{"bodies": ["liver", "gallbladder"], "reach_mm": 3}],
        "contact": {"rest_overlap_tolerance_mm": 6}})",
      "w.json");
  const auto ready = io::make_ready_world(w);
  ASSERT_EQ(ready->ids.size(), 2u);
  const world::Attachment& bed = world::attachment(ready->world, ready->attachments[0]);
  EXPECT_GT(bed.ties.size(), 50u);
  // Ties join the organs where they touch: every tie's ends within reach of each other.
  for (const world::Tie& t : bed.ties) {
    const auto [p, q] = world::tie_ends(ready->world, t);
    EXPECT_LE((p - q).norm(), 3.0 + 1e-9);
  }
  // A blade along the whole bed, wide and deep: every tie divided, and no other.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const world::Tie& t : bed.ties) {
    const Eigen::Vector3d mid =
        0.5 * (world::tie_ends(ready->world, t).first + world::tie_ends(ready->world, t).second);
    lo = lo.cwiseMin(mid);
    hi = hi.cwiseMax(mid);
  }
  world::Dissection cut;
  cut.blade.path = {Eigen::Vector3d(lo.x() - 5, lo.y() - 5, 0.5 * (lo.z() + hi.z())),
                    Eigen::Vector3d(hi.x() + 5, hi.y() + 5, 0.5 * (lo.z() + hi.z()))};
  cut.blade.depth_direction = Eigen::Vector3d(1, -1, 0);
  cut.blade.depth_mm = 1e-3;  // a thin edge swept along the path: reach carries the rest
  cut.reach_mm = (hi - lo).norm();
  cut.blade.start_s = 0.0;
  cut.blade.end_s = 1.0;
  EXPECT_EQ(world::advance_dissections({cut}, ready->world, 2.0, 3.0), 0);  // after it ended
  const int32_t divided = world::advance_dissections({cut}, ready->world, 0.0, 1.0);
  EXPECT_EQ(divided, static_cast<int32_t>(bed.ties.size()));
  EXPECT_EQ(world::count_ties(ready->world).divided, static_cast<int64_t>(bed.ties.size()));
}

TEST(BuildOrgans, OverlappingMasksGiveEachVoxelToOneOrganAndStructuresStayInTheirs) {
  const std::string data = test::source_path("tests/data").string();
  const LabelVolume labels =
      io::read_label_volume(data + "/liver_totalseg_example_3mm_labels.nii.gz");
  // The liver's mask grown by a voxel into its neighbours: it overlaps the gallbladder's.
  auto liver = std::make_shared<LabelVolume>(labels);
  auto gallbladder = std::make_shared<LabelVolume>(labels);
  const GridFrame& f = labels.frame;
  int64_t liver_voxels = 0, gallbladder_voxels = 0, union_voxels = 0;
  for (int64_t z = 0; z < f.size[2]; ++z)
    for (int64_t y = 0; y < f.size[1]; ++y)
      for (int64_t x = 0; x < f.size[0]; ++x) {
        const int64_t i = f.index(x, y, z);
        bool near_liver = labels.labels[static_cast<size_t>(i)] == 1;
        if (x > 0) near_liver |= labels.labels[static_cast<size_t>(f.index(x - 1, y, z))] == 1;
        if (z > 0) near_liver |= labels.labels[static_cast<size_t>(f.index(x, y, z - 1))] == 1;
        near_liver &= labels.labels[static_cast<size_t>(i)] != 2;  // the portal vein stays out
        const bool is_gb = labels.labels[static_cast<size_t>(i)] == 4;
        liver->labels[static_cast<size_t>(i)] = near_liver;
        gallbladder->labels[static_cast<size_t>(i)] = is_gb;
        liver_voxels += near_liver;
        gallbladder_voxels += is_gb;
        union_voxels += near_liver || is_gb;
      }
  model::BuildOptions options;
  options.skin_vertices = 800;
  options.display_triangles = 0;
  options.embed.push_back({.name = "portal_vein", .label = 2});
  liver->source = "liver mask";
  gallbladder->source = "gallbladder mask";
  const model::OrgansResult r = model::build_organs(
      labels, {{.name = "liver", .mask = liver}, {.name = "gallbladder", .mask = gallbladder}},
      options);
  ASSERT_EQ(r.organs.size(), 2u);
  ASSERT_EQ(r.overlaps.size(), 1u);
  const int64_t overlap = liver_voxels + gallbladder_voxels - union_voxels;
  EXPECT_GT(overlap, 0);
  EXPECT_EQ(r.overlaps[0].voxels, overlap);
  // Each voxel given once: the organs' voxels add up to the union.
  EXPECT_EQ(r.organs[0].voxels + r.organs[1].voxels, union_voxels);
  EXPECT_EQ(r.organs[0].structures, std::vector<std::string>{"portal_vein"});
  EXPECT_TRUE(r.organs[1].structures.empty());
  ASSERT_EQ(r.contacts.size(), 1u);
  EXPECT_GT(r.contacts[0].faces, 0);
  // The gallbladder's skin is meshed at the liver's density: fewer vertices on a smaller skin.
  EXPECT_LT(r.organs[1].built.model.layers[0].node_count,
            r.organs[0].built.model.layers[0].node_count);
  EXPECT_GE(r.organs[1].built.model.layers[0].node_count, 150);
}

TEST(BuildOrgans, ALabelTheSegmentationLacksOrAStructureAwayFromEveryOrganIsRefused) {
  const std::string data = test::source_path("tests/data").string();
  const LabelVolume labels =
      io::read_label_volume(data + "/liver_totalseg_example_3mm_labels.nii.gz");
  model::BuildOptions options;
  try {
    model::build_organs(labels, {{.name = "liver", .label = 1}, {.name = "spleen", .label = 9}},
                        options);
    FAIL() << "label 9 was built";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("organ 'spleen': the segmentation has no voxel of label 9"),
        std::string::npos)
        << e.what();
  }
  // The vena cava (label 3) beside the gallbladder alone? It touches the liver, not the
  // gallbladder: given only the gallbladder, it lies against no organ.
  options.embed.push_back({.name = "vena_cava", .label = 3});
  try {
    model::build_organs(labels, {{.name = "gallbladder", .label = 4}}, options);
    FAIL() << "a structure away from every organ was built";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("structure 'vena_cava' lies in or against none"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace lamina
