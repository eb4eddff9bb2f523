// The --tile option of fit and render: "X,Y,W,H", or "auto:WxH" for the most seamless tile of
// that size (ranges allowed, e.g. auto:20-28x24), found by find_seamless_tile().
#pragma once

#include <fmt/format.h>

#include <string>

#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/tile.hpp"
#include "cli_util.hpp"

namespace btfgmm::cli {

inline bool is_auto_tile(const std::string& text) {
  return text.rfind("auto:", 0) == 0;
}

// The tile a --tile value asks for (empty: the whole image). For auto:, the search's choice
// and its seam error are reported on stderr unless `quiet`.
inline btfgmm::Tile tile_option(const btfgmm::BtfSource& src, const std::string& text, bool quiet) {
  if (text.empty()) return {};
  if (!is_auto_tile(text)) return parse_tile(text);
  const auto t0 = Clock::now();
  const btfgmm::TileSearchConfig c = btfgmm::parse_tile_search_size(text.substr(5), "--tile auto:");
  const btfgmm::TileSearchResult r = btfgmm::find_seamless_tile(src, c);
  if (!quiet)
    fmt::print(stderr,
               "tile {},{},{},{}: seam error {:.3f} (left-right {:.3f}, top-bottom {:.3f}; 0 = "
               "seamless), chosen among {} on {} images in {}\n",
               r.tile.x, r.tile.y, r.tile.width, r.tile.height, r.seam.total, r.seam.left_right,
               r.seam.top_bottom, r.candidates, r.images, human_seconds(seconds_since(t0)));
  return r.tile;
}

}  // namespace btfgmm::cli
