#pragma once
// The files of a run's VTK time series, shared by `lamina run` on one organ (run_command.cpp)
// and on a world (world_run.cpp): frames/NAME_000000.vtp listed with their times in NAME.pvd.

#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace lamina::cli {

/// Frames of an earlier run in the same folder would be mistaken for this run's (a longer
/// earlier run leaves higher-numbered files); only names of `series` (and a cut's pieces'
/// series) are removed, and a resumed run keeps the `keep` frames written before its checkpoint.
void remove_stale_frames(const std::filesystem::path& frames, const std::set<std::string>& series,
                         int32_t keep);

/// A series' file name for a surface: its name with anything but letters, digits, '-', '_' and
/// '.' made '_' ("label 2" -> "label_2"), and made unique among `taken` ("skin" -> "skin_2").
std::string series_name(const std::string& surface, const std::set<std::string>& taken);

/// ParaView's collection format: OUT/NAME.pvd, one DataSet per frame (time s, path relative to
/// OUT), written atomically.
void write_pvd(const std::filesystem::path& out, const std::string& name,
               const std::vector<std::pair<double, std::string>>& files);

}  // namespace lamina::cli
