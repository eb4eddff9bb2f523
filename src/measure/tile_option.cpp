#include "btfgmm/measure/tile_option.hpp"

#include <fmt/format.h>

#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/parse.hpp"

namespace btfgmm {
namespace {

constexpr const char* kAuto = "auto:";

// "X,Y,W,H": whole pixels, x and y >= 0, width and height >= 1.
Tile parse_tile(const std::string& text, const std::string& option) {
  const auto v = parse_numbers(text, option, 4, "0,0,25,25 (x,y,width,height in pixels)");
  for (double d : v)
    if (d != std::floor(d) || std::abs(d) > 1e9)
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} '{}' needs whole pixel numbers, like 0,0,25,25", option, text));
  if (v[2] < 1 || v[3] < 1 || v[0] < 0 || v[1] < 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': x, y must be >= 0 and width, height >= 1", option, text));
  return {.x = int(v[0]), .y = int(v[1]), .width = int(v[2]), .height = int(v[3])};
}

}  // namespace

TileOption parse_tile_option(const std::string& text, const std::string& option) {
  TileOption t;
  if (text.empty()) return t;
  if (text.rfind(kAuto, 0) == 0)
    t.search = parse_tile_search_size(text.substr(std::string(kAuto).size()),
                                      fmt::format("{} {}", option, kAuto));
  else
    t.tile = parse_tile(text, option);
  return t;
}

bool can_cut_seamless_tile(const BtfInfo& info, int width, int height) {
  return width >= 4 && height >= 4 && info.width >= width + 2 && info.height >= height + 2;
}

TileChoice choose_tile(const BtfSource& source, const std::string& text,
                       const std::string& option) {
  const TileOption t = parse_tile_option(text, option);
  if (!t.search) return {t.tile, std::nullopt, std::nullopt, source};
  TileChoice c{{}, find_seamless_tile(source, *t.search), std::nullopt, source};
  c.tile = c.search->tile;
  if (c.search->seam.total < kSeamlessCropError ||
      !can_cut_seamless_tile(source.info(), c.tile.width, c.tile.height))
    return c;
  SeamlessTileConfig config;
  config.width = c.tile.width;
  config.height = c.tile.height;
  c.cut = cut_seamless_tile(source, config);
  c.source = seamless_tile_source(source, *c.cut);
  c.tile = {};
  return c;
}

BtfSource fitted_source(const BtfSource& source, const Provenance& provenance) {
  for (const auto& [name, value] : provenance.fit.settings)
    if (name == kTileSetting) return made_tile_source(source, value);
  return source;
}

}  // namespace btfgmm
