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

TileChoice choose_tile(const BtfSource& source, const std::string& text,
                       const std::string& option) {
  const TileOption t = parse_tile_option(text, option);
  if (!t.search) return {t.tile, std::nullopt};
  const TileSearchResult r = find_seamless_tile(source, *t.search);
  return {r.tile, r};
}

}  // namespace btfgmm
