// name_key and is_tumour_name (structure_names.h).
#include "lamina/geometry/structure_names.h"

#include <cctype>

namespace lamina::geometry {

std::string name_key(const std::string& name) {
  std::string out;
  for (const char c : name)
    if (c != ' ' && c != '_' && c != '-')
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool is_tumour_name(const std::string& name) {
  const std::string n = name_key(name);
  for (const char* t :
       {"tumo", "lesion", "mass", "metasta", "carcinom", "hcc", "cancer", "neoplas", "nodule"})
    if (n.find(t) != std::string::npos) return true;
  return false;
}

}  // namespace lamina::geometry
