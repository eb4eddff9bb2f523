// Angles as image and folder names write them (image_names.cpp), for the data-set reader and
// the UTIA writer.
#pragma once

#include <optional>
#include <string>

#include "btfgmm/core/directions.hpp"

namespace btfgmm::detail {

// A direction as a name writes it: angles(d, "tv", "pv", '_') is "tv030_pv060".
std::string angles(const Direction& d, const char* t, const char* p, char sep);
// A folder named after a view: tv030_pv060 (or with a space); the view it names.
std::optional<Direction> parse_view_folder(const std::string& folder);

}  // namespace btfgmm::detail
