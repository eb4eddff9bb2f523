// The --tile option of fit and render: the library parses it and, for "auto:WxH", makes a
// seamless tile (or searches the crop that repeats best, btfgmm/measure/tile_option.hpp); the
// command reports which.
#pragma once

#include <fmt/format.h>

#include <string>

#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/tile_option.hpp"

namespace btfgmm::cli {

// How every --tile option's help says what auto:WxH does.
inline constexpr const char* kAutoTileHelp =
    "auto:WxH for a seamless tile of that size (the best crop where it repeats cleanly, else one "
    "cut along the seams of least error, as tile -o makes it)";

// The search's choice and its seam error, on stderr.
inline void print_tile_search(const btfgmm::TileSearchResult& r, double seconds) {
  fmt::print(stderr,
             "tile {},{},{},{}: seam error {:.3f} (left-right {:.3f}, top-bottom {:.3f}; 0 = "
             "seamless), chosen among {} on {} images in {}\n",
             r.tile.x, r.tile.y, r.tile.width, r.tile.height, r.seam.total, r.seam.left_right,
             r.seam.top_bottom, r.candidates, r.images, human_seconds(seconds));
}

// The made tile, its cut's cost against the material's own steps, on stderr.
inline void print_tile_cut(const btfgmm::SeamlessTile& t, double seconds) {
  fmt::print(stderr,
             "tile: {}, its cuts {:.2f} levels RMS apart against {:.2f} between neighbouring "
             "pixels, on {} images in {}\n",
             t.describe(), t.cost.cut_levels, t.cost.neighbour_levels, t.images,
             human_seconds(seconds));
}

// The tile a --tile value asks for (empty: the whole image). For auto:, `src` becomes the
// made tile where one is cut (its whole image the tile), and the cut or the search's choice
// is reported on stderr unless `quiet`.
inline btfgmm::Tile tile_option(btfgmm::BtfSource& src, const std::string& text, bool quiet) {
  const auto t0 = Clock::now();
  btfgmm::TileChoice choice = btfgmm::choose_tile(src, text, "--tile");
  if (choice.search && !quiet && !choice.cut) print_tile_search(*choice.search, seconds_since(t0));
  if (choice.search && !quiet && choice.cut)
    fmt::print(stderr,
               "the best {}x{} crop ({},{}) has a seam error of {:.3f} (0 = seamless, above 1 a "
               "visible seam): a seamless tile is made instead\n",
               choice.search->tile.width, choice.search->tile.height, choice.search->tile.x,
               choice.search->tile.y, choice.search->seam.total);
  if (choice.cut && !quiet) print_tile_cut(*choice.cut, seconds_since(t0));
  src = std::move(choice.source);
  return choice.tile;
}

}  // namespace btfgmm::cli
