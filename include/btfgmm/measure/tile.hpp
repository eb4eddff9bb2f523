// Seamless tiles: the tile of a BTF that can be repeated with the least visible seams (the
// paper cuts such tiles before fitting, its ref. [22]).
//
// Repeating a tile puts its first column next to its last one (and its first row under its
// last one). The seam is invisible when the column the tile brings there is the column the
// texture itself continues with. A candidate tile (x0, y0, w, h) is judged on a sample of the
// (light, view) images by
//   left-right: the mean over the tile's rows, the channels and the images of
//     (I(x0 + w, y) - I(x0, y))^2        right of the tile: the texture's next column against
//                                        the tile's first one, and
//     (I(x0 - 1, y) - I(x0 + w - 1, y))^2  left of it: the texture's previous column against
//                                        the tile's last one,
//     where those columns lie inside the image, divided by the mean squared difference of
//     horizontally neighbouring pixels of the images (the texture's own neighbour
//     differences);
//   top-bottom: the same for rows.
// So 0 is a tile that repeats exactly like the texture continues (a whole number of
// periods of a periodic texture); a tile cut at a random place scores well above 1 on most
// textures. The search tries every position of every size in the requested ranges and
// returns the tile of the lowest score, its seam error times its aspect ratio (longer side /
// shorter side; ties: the larger tile, then the top-left one): a tile twice as long as it is
// wide must have half the seam error of a square one. A narrow strip is a poor sample of the
// material however well it repeats, and with ranges of sizes the seam error alone tends to
// pick one (it is judged on fewer pixels, so chance matches weigh more).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/dataset.hpp"

namespace btfgmm {

struct TileSearchConfig {
  int min_width = 32, max_width = 32;
  int min_height = 32, max_height = 32;
  // The (light, view) images the seams are judged on, spread evenly over all pairs in the
  // light-major order; 0: all of them.
  std::size_t images = 64;
  // How many of the best sizes TileSearchResult::ranked lists (at least 1).
  std::size_t top = 1;
};

struct SeamError {
  double left_right = 0.0;  // relative to the neighbour differences (see above)
  double top_bottom = 0.0;
  double total = 0.0;       // (left_right + top_bottom) / 2
  double rms_levels = 0.0;  // root mean squared mismatch over both seams, in levels
};

// A tile and how it ranks.
struct TileCandidate {
  Tile tile;
  SeamError seam;
  double score = 0.0;  // tile_score(): what the search minimises
};

struct TileSearchResult {
  Tile tile;  // the best: ranked[0]
  SeamError seam;
  double score = 0.0;
  std::size_t candidates = 0;  // tiles compared
  std::size_t images = 0;      // images the seams were judged on
  // The best position of each of the `config.top` best sizes, best first.
  std::vector<TileCandidate> ranked;
};

// What the search minimises: the seam error times the aspect ratio, longer side / shorter side.
double tile_score(const SeamError& seam, int width, int height);

// Throws Error(kArgument) when a size range is empty or a tile size is not smaller than the
// image (a seam needs a column or row outside the tile to be judged).
TileSearchResult find_seamless_tile(const Btf& btf, const TileSearchConfig& config);
// Reads only the sampled images, whole, one batch at a time.
TileSearchResult find_seamless_tile(const BtfSource& source, const TileSearchConfig& config);
TileSearchResult find_seamless_tile(const BtfSource& source, int width, int height);

// The seam error of one tile, on `images` images spread as in the search (0: all).
SeamError seam_error(const Btf& btf, const Tile& tile, std::size_t images = 64);

// "WxH" with W and H each a number or a range "A-B", e.g. "32x32" or "20-28x24". Throws
// Error(kArgument) naming `option` and showing the form.
TileSearchConfig parse_tile_search_size(const std::string& text, const std::string& option);

}  // namespace btfgmm
