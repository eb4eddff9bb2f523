// The made tile's pixel map as JSON (include/btfgmm/measure/seamless_tile.hpp).
#include <nlohmann/json.hpp>

#include "btfgmm/measure/seamless_tile.hpp"

namespace btfgmm {

std::string seamless_tile_json(const SeamlessTile& tile, const BtfInfo& source) {
  const PixelMap m = tile.pixel_map(tile.describe());
  nlohmann::json pixels = nlohmann::json::array();
  for (const auto& taps : m.source) {
    nlohmann::json pixel = nlohmann::json::array();
    for (const PixelTap& t : taps)
      if (t.weight > 0.0f)
        pixel.push_back({m.region.x + int(t.dx), m.region.y + int(t.dy), t.weight});
    pixels.push_back(pixel);
  }
  const nlohmann::json j = {
      {"what",
       "a seamless tile cut from a larger region of each image along the cuts of least "
       "error, feathered over a few pixels across each cut; pixel (x, y) of every tile "
       "image is the sum over pixels[y * width + x] of [X, Y, weight] of weight times "
       "the source image's pixel (X, Y), rounded to a level for 8-bit data"},
      {"source", source.path.string()},
      {"source_size", {source.width, source.height}},
      {"width", tile.width},
      {"height", tile.height},
      {"region", {tile.region.x, tile.region.y, tile.region.width, tile.region.height}},
      {"overlap", {tile.overlap_x, tile.overlap_y}},
      {"column_cut", tile.column_cut},
      {"row_cut", tile.row_cut},
      {"cut_levels_rms", tile.cost.cut_levels},
      {"neighbour_levels_rms", tile.cost.neighbour_levels},
      {"images", tile.images},
      {"positions", tile.positions},
      {"pixels", pixels}};
  return j.dump() + "\n";
}

}  // namespace btfgmm
