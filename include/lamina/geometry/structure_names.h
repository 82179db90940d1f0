#pragma once
/// \file
/// What a structure's name says: the resection plan's tumours (their margins) and the viewer's
/// colours read it the same way.

#include <string>

namespace lamina::geometry {

/// A structure's name as compared: lower case, without spaces, '_' and '-' ("Portal_Vein" and
/// "portal vein" alike).
std::string name_key(const std::string& name);

/// True for names that say tumour: "tumour", "lesion", "metastasis", "HCC", ... (any case, with
/// or without '_', '-' or spaces).
bool is_tumour_name(const std::string& name);

}  // namespace lamina::geometry
