// The --tile option of fit and render: the library parses it and, for "auto:WxH", searches
// the most seamless tile (btfgmm/measure/tile_option.hpp); the command reports the search.
#pragma once

#include <fmt/format.h>

#include <string>

#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/tile_option.hpp"

namespace btfgmm::cli {

// The search's choice and its seam error, on stderr.
inline void print_tile_search(const btfgmm::TileSearchResult& r, double seconds) {
  fmt::print(stderr,
             "tile {},{},{},{}: seam error {:.3f} (left-right {:.3f}, top-bottom {:.3f}; 0 = "
             "seamless), chosen among {} on {} images in {}\n",
             r.tile.x, r.tile.y, r.tile.width, r.tile.height, r.seam.total, r.seam.left_right,
             r.seam.top_bottom, r.candidates, r.images, human_seconds(seconds));
}

// The tile a --tile value asks for (empty: the whole image). For auto:, the search's choice
// and its seam error are reported on stderr unless `quiet`.
inline btfgmm::Tile tile_option(const btfgmm::BtfSource& src, const std::string& text, bool quiet) {
  const auto t0 = Clock::now();
  const btfgmm::TileChoice choice = btfgmm::choose_tile(src, text, "--tile");
  if (choice.search && !quiet) print_tile_search(*choice.search, seconds_since(t0));
  return choice.tile;
}

}  // namespace btfgmm::cli
