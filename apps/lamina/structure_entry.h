#pragma once
// The command line's structure entries (lamina build --embed / --embed-mask, lamina resect
// --embed): LABEL[=NAME][:ROLE] and FILE[=NAME][:ROLE]. The role (vessel, tumour, structure) is
// what the structure is, stored with it; without one it is the role the name suggests
// (geometry::guess_role), reported by the build.

#include <charconv>
#include <optional>
#include <string>

#include "lamina/core/error.h"
#include "lamina/core/surface_role.h"

namespace lamina::cli {

struct StructureEntry {
  std::string source;               ///< the label's digits, or the mask's file
  std::string name;                 ///< empty: none given
  std::optional<SurfaceRole> role;  ///< none: from the name
};

/// Splits "TEXT[=NAME][:ROLE]". A ':' starts the role only where what follows the last one is a
/// role's name (a path may hold ':'); an unknown one after '=' is refused, naming the option.
inline StructureEntry split_structure_entry(const std::string& entry, const char* option) {
  StructureEntry e;
  std::string rest = entry;
  const size_t colon = rest.rfind(':');
  if (colon != std::string::npos) {
    const std::string word = rest.substr(colon + 1);
    if (const auto r = role_from_name(word)) {
      e.role = *r;
      rest.resize(colon);
    } else if (rest.find('=') != std::string::npos && rest.find('=') < colon) {
      throw invalid_input(
          option, "'" + entry + "': '" + word + "' is not a role (vessel, tumour or structure)");
    }
  }
  const size_t eq = rest.find('=');
  e.source = rest.substr(0, eq);
  if (eq != std::string::npos) e.name = rest.substr(eq + 1);
  return e;
}

/// The label of a LABEL[=NAME][:ROLE] entry: a number > 0, or a one-line refusal.
inline int32_t entry_label(const StructureEntry& e, const std::string& entry, const char* option) {
  int32_t label = 0;
  const auto [end, ec] = std::from_chars(e.source.data(), e.source.data() + e.source.size(), label);
  if (ec != std::errc() || end != e.source.data() + e.source.size() || label <= 0)
    throw invalid_input(option,
                        "'" + entry + "' is not LABEL[=NAME][:ROLE] with LABEL a number > 0");
  return label;
}

}  // namespace lamina::cli
