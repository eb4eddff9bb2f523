// btfgmm tile's arguments, shared by its two halves: the crop search (cmd_tile.cpp) and the
// seamless tile it makes with -o (tile_made.cpp).
#pragma once

#include <cstddef>
#include <string>

namespace btfgmm::cli {

struct TileArguments {
  std::string input, size = "32x32", out, format;
  std::size_t images = 64, top = 1;
  int overlap = 0;
  bool json = false, overwrite = false, quiet = false;
};

// tile -o TILE/: cuts the seamless tile, writes it as a UTIA folder with seamless-tile.json
// beside its images, and reports how its wrap and cut compare with the material's own steps.
void run_made_tile(const TileArguments& o);

}  // namespace btfgmm::cli
