// The report's (light, view) grid pictures: a PNG of ni rows (lights) x nv columns (views)
// framed with the elevation rings of both direction sets, and the colour bar of the PSNR map.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm::svg {

// A (light, view) grid picture with ring ticks on both axes: rows = lights, columns = views,
// each `cell` pixels. `outline` pairs (light, view) are marked with a square; `legend_svg`
// (`legend_width` pixels wide) goes to the right of the grid.
std::string grid_svg(const std::string& png, const DirectionSet& lights, const DirectionSet& views,
                     int cell, const std::vector<std::pair<std::size_t, std::size_t>>& outline,
                     const std::string& legend_svg, int legend_width);

// A vertical colour bar of the viridis map (colour_map) from lo_db (bottom) to hi_db (top),
// `height` pixels, its gradient named `id`.
std::string colour_bar(double lo_db, double hi_db, int height, const std::string& id);
// A vertical grey bar from black (lo, bottom) to white (hi, top), ticked in `unit`: the scale of
// a picture whose grey level is proportional to a value.
std::string grey_bar(double lo, double hi, int height, const std::string& id,
                     const std::string& unit);

}  // namespace btfgmm::svg
