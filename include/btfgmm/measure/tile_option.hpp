// The --tile option of fit and render, parsed in one place: "X,Y,W,H" in pixels, or
// "auto:WxH" for the most seamless tile of that size (W and H each a number or a range, e.g.
// auto:20-28x24), found by find_seamless_tile (tile.hpp). Empty: the whole image.
#pragma once

#include <optional>
#include <string>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/tile.hpp"

namespace btfgmm {

struct TileOption {
  Tile tile;                               // "X,Y,W,H"; empty for "" and for "auto:"
  std::optional<TileSearchConfig> search;  // "auto:WxH": the sizes to search
};

// Throws Error(kArgument) naming `option` and the value, and showing the form.
TileOption parse_tile_option(const std::string& text,
                             const std::string& option = option_name("tile"));

struct TileChoice {
  Tile tile;                               // empty: the whole image
  std::optional<TileSearchResult> search;  // for "auto:": how the tile was chosen
};

// The tile a --tile value asks for in `source`: the given one, or the search's choice (read
// from `source` as find_seamless_tile does). Throws as parse_tile_option and the search.
TileChoice choose_tile(const BtfSource& source, const std::string& text,
                       const std::string& option = option_name("tile"));

}  // namespace btfgmm
