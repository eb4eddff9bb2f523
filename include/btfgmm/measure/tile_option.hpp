// The --tile option of fit and render, parsed in one place: "X,Y,W,H" in pixels, or
// "auto:WxH" for a seamless tile of that size (W and H each a number or a range, e.g.
// auto:20-28x24): the crop that repeats best (find_seamless_tile, tile.hpp), measured data
// unchanged, where its seam differs less than neighbouring pixels do (kSeamlessCropError);
// else one made by cutting (cut_seamless_tile, seamless_tile.hpp) at the crop's size, where the
// images hold the tile and an overlap of at least 2 in each direction. Empty: the whole image.
#pragma once

#include <optional>
#include <string>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/seamless_tile.hpp"
#include "btfgmm/measure/tile.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {

// The seam error (relative to neighbouring pixels, tile.hpp) below which "auto:" keeps the crop.
inline constexpr double kSeamlessCropError = 1.0;

struct TileOption {
  Tile tile;                               // "X,Y,W,H"; empty for "" and for "auto:"
  std::optional<TileSearchConfig> search;  // "auto:WxH": the sizes to search
};

// Throws Error(kArgument) naming `option` and the value, and showing the form.
TileOption parse_tile_option(const std::string& text,
                             const std::string& option = option_name("tile"));

struct TileChoice {
  Tile tile;                               // of `source`; empty: the whole image
  std::optional<TileSearchResult> search;  // for "auto:": the best crop
  std::optional<SeamlessTile> cut;         // for "auto:": the made tile, when it could be cut
  BtfSource source;                        // the data to read `tile` of: the made tile's, or
                                           // the source as given
};

// The tile a --tile value asks for in `source`: the given one, or for "auto:" the made tile
// (or the search's choice, read from `source` as find_seamless_tile does). Throws as
// parse_tile_option, the cut and the search.
TileChoice choose_tile(const BtfSource& source, const std::string& text,
                       const std::string& option = option_name("tile"));

// The data a model was fitted to, in `source` (its tile the model's own frame): for a model of
// a made tile (its provenance's setting kTileSetting) that tile made again from `source`,
// else `source` itself. Throws as made_tile_again.
BtfSource fitted_source(const BtfSource& source, const Provenance& provenance);

// Whether a seamless WxH tile can be cut from `info`'s images (an overlap of at least 2).
bool can_cut_seamless_tile(const BtfInfo& info, int width, int height);

}  // namespace btfgmm
