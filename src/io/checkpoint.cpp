// Checkpoint files: a fixed header (magic, version, payload size, CRC-32 of the payload) and a
// payload of little-endian fields written in one order and read back in the same order. Every
// count is checked against the bytes that remain before anything is allocated, so a corrupt or
// hostile file can neither crash the reader nor make it allocate more than the file's size.
#include "lamina/io/checkpoint.h"

#include <zlib.h>

#include <bit>
#include <cstring>
#include <type_traits>

#include "checkpoint_internal.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "read_file.h"

namespace lamina::io {
namespace {

using namespace checkpoint_detail;

static_assert(std::endian::native == std::endian::little, "checkpoints are little-endian");

constexpr char kMagic[8] = {'L', 'A', 'M', 'C', 'K', 'P', 'T', '\n'};
// Version 2 added each series' name and a run's scalpels (a cut model); version 1 still reads.
// Version 3 added the role of each surface and structure a scalpel section holds.
// Version 4 added whether a cut event split the fine surfaces without dividing tetrahedra.
// Version 5 added how many of a scalpel's blade columns its surfaces are split along.
constexpr uint32_t kVersion = 5;
constexpr size_t kHeaderBytes = 8 + 4 + 8 + 4;

}  // namespace

uint32_t file_crc(const std::string& path) {
  const std::string bytes = detail::read_whole_file(path);
  return crc(0, bytes.data(), bytes.size());
}

void save_checkpoint(const RunCheckpoint& k, const std::string& path) {
  Writer w;
  w.str(k.scene_path);
  w.pod(k.scene_crc);
  w.pod(k.model_crc);
  w.pod(k.threads);
  const sim::SimState& s = k.state;
  for (const Eigen::MatrixX3d* m : {&s.x, &s.v, &s.f_ext, &s.dv}) w.mat(*m);
  w.pod(s.time_s);
  w.pod(s.steps);
  w.pod(s.recoveries);
  w.vec(s.fixed);
  w.vec(s.movable);
  w.vec(k.tool_active);
  w.pod<uint64_t>(k.routes.size());
  for (const interact::ForceRoute& r : k.routes) {
    w.pod(r.contact_node);
    w.vec(r.crossings);
    w.vec(r.nodes);
    w.mat(r.forces);
  }
  w.vec(k.touched);
  w.vec(k.loads.nodes);
  w.pod<uint8_t>(k.loads.cleared ? 1 : 0);
  w.pod(k.progress.loop_step);
  w.pod(k.progress.quiet_streak);
  w.pod(k.progress.frame);
  w.pod(k.progress.next_frame_s);
  w.pod(k.progress.max_displacement_mm);
  w.pod(k.progress.max_abs_volume_change_pct);
  w.pod(k.progress.max_reaction_mn);
  w.str(k.progress.metrics_csv);
  w.pod<uint64_t>(k.frames.size());
  for (const FrameList& list : k.frames) {
    w.pod<uint64_t>(list.size());
    for (const auto& [time, file] : list) {
      w.pod(time);
      w.str(file);
    }
  }
  w.pod<uint64_t>(k.series_names.size());
  for (const std::string& name : k.series_names) w.str(name);
  w.pod<uint8_t>(k.scalpels ? 1 : 0);
  if (k.scalpels) write_scalpels(w, *k.scalpels);

  Writer h;
  h.bytes(kMagic, sizeof kMagic);
  h.pod(kVersion);
  h.pod<uint64_t>(w.out.size());
  h.pod(crc(0, w.out.data(), w.out.size()));
  write_file_atomically(
      path, [&](std::ostream& f) { f << h.out << w.out; }, /*binary=*/true);
}

RunCheckpoint load_checkpoint(const std::string& path) {
  const std::string file = detail::read_whole_file(path);
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };
  if (file.size() < kHeaderBytes || std::memcmp(file.data(), kMagic, sizeof kMagic) != 0)
    throw bad("not a Lamina checkpoint (it does not start with the checkpoint header)");
  Reader head{path, file.data() + sizeof kMagic, file.data() + kHeaderBytes};
  const auto version = head.pod<uint32_t>();
  const auto payload = head.pod<uint64_t>();
  const auto sum = head.pod<uint32_t>();
  if (version < 1 || version > kVersion)
    throw bad("checkpoint format version " + std::to_string(version) + ", this build reads 1 to " +
              std::to_string(kVersion) + ": resume it with the Lamina that wrote it");
  if (payload != file.size() - kHeaderBytes)
    throw bad("checkpoint is truncated: the header announces " + std::to_string(payload) +
              " bytes of data, the file holds " + std::to_string(file.size() - kHeaderBytes));
  const char* data = file.data() + kHeaderBytes;
  if (crc(0, data, payload) != sum)
    throw bad("checkpoint is corrupt: its checksum does not match its contents");

  Reader r{path, data, data + payload, version};
  RunCheckpoint k;
  k.scene_path = r.str();
  k.scene_crc = r.pod<uint32_t>();
  k.model_crc = r.pod<uint32_t>();
  k.threads = r.pod<int32_t>();
  sim::SimState& s = k.state;
  for (Eigen::MatrixX3d* m : {&s.x, &s.v, &s.f_ext, &s.dv}) *m = r.mat();
  s.time_s = r.pod<double>();
  s.steps = r.pod<int64_t>();
  s.recoveries = r.pod<int64_t>();
  s.fixed = r.vec<uint8_t>();
  s.movable = r.vec<uint8_t>();
  k.tool_active = r.vec<uint8_t>();
  k.routes.resize(r.count(sizeof(int32_t) + 3 * sizeof(uint64_t)));
  for (interact::ForceRoute& route : k.routes) {
    route.contact_node = r.pod<int32_t>();
    route.crossings = r.vec<interact::Crossing>();
    route.nodes = r.vec<int32_t>();
    route.forces = r.mat();
    if (route.forces.rows() != static_cast<Eigen::Index>(route.nodes.size()))
      throw bad("checkpoint is inconsistent: a tool's force rows differ from its nodes");
  }
  k.touched = r.vec<int32_t>();
  k.loads.nodes = r.vec<int32_t>();
  k.loads.cleared = r.pod<uint8_t>() != 0;
  k.progress.loop_step = r.pod<int64_t>();
  k.progress.quiet_streak = r.pod<int64_t>();
  k.progress.frame = r.pod<int32_t>();
  k.progress.next_frame_s = r.pod<double>();
  k.progress.max_displacement_mm = r.pod<double>();
  k.progress.max_abs_volume_change_pct = r.pod<double>();
  k.progress.max_reaction_mn = r.pod<double>();
  k.progress.metrics_csv = r.str();
  k.frames.resize(r.count(sizeof(uint64_t)));
  for (FrameList& list : k.frames) {
    list.resize(r.count(sizeof(double) + sizeof(uint64_t)));
    for (auto& [time, name] : list) {
      time = r.pod<double>();
      name = r.str();
    }
  }
  if (version >= 2) {
    k.series_names.resize(r.count(sizeof(uint64_t)));
    for (std::string& name : k.series_names) name = r.str();
    if (!k.series_names.empty() && k.series_names.size() != k.frames.size())
      throw bad("checkpoint is inconsistent: " + std::to_string(k.series_names.size()) +
                " series names for " + std::to_string(k.frames.size()) + " frame lists");
    if (r.pod<uint8_t>() != 0) k.scalpels = read_scalpels(r);
  }
  if (r.p != r.end) throw bad("checkpoint is inconsistent: data left over after its last field");
  return k;
}

}  // namespace lamina::io
