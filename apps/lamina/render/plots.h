#pragma once
// gnuplot plots for the CLI's reports (lamina figures, lamina validate).

#include <filesystem>
#include <string>

namespace lamina::cli {

/// The gnuplot executable on PATH, or lamina::Error (kUnavailable) saying how to install it.
std::string find_gnuplot();
/// Writes `text` to `path` atomically.
void write_text(const std::filesystem::path& path, const std::string& text);
/// gnuplot's quoting of a path (single quotes, ' doubled).
std::string quote(const std::filesystem::path& p);
/// Writes DIR/NAME.gp (`header`, the output line, then `body`) and draws DIR/NAME.png with it;
/// a failed plot leaves no half-written picture.
void draw_plot(const std::string& gnuplot, const std::filesystem::path& dir,
               const std::string& name, const std::string& header, const std::string& body);
/// The common look: PNG 1000x640, CSV input, grid, boxed key.
extern const char* const kPlotStyle;

}  // namespace lamina::cli
