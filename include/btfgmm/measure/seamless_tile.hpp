// Seamless tiles made by cutting (the paper's ref. [22]): a W x H tile whose wrap continues the
// texture in every (light, view) image, stitched from a larger region of the data along the
// cuts of least error through the overlap of its opposite edges.
//
// The region R (W + ox) x (H + oy) at (x0, y0) has two strips that both lie where the tile's
// first ox columns go when it repeats: A, its first ox columns, which the tile's interior
// continues, and B, the ox columns W positions to the right, which continue the tile's last
// column. Column j of the overlap is taken from B left of a cut p(r) and from A from it on:
// tile(j, r) = R(j + W, r) for j < p(r), R(j, r) otherwise. So the wrap (last column, then
// first) is a step between neighbours of the data, and the only new steps are along the cut,
// between B(p - 1) and A(p). The cut is the path through the overlap of least cost, the cost
// of putting two pixels s, t of different strips side by side being
//   M(s, t) = ||A(s) - B(s)|| + ||A(t) - B(t)||
// (Kwatra, Schödl, Essa, Turk and Bobick, "Graphcut textures", SIGGRAPH 2003, Eq. 1), the norm
// over every image and channel: one cut for all (light, view) images, so that the tile is one
// consistent material. The path, one column per row, moving at most one column between rows
// (Efros and Freeman, "Image quilting for texture synthesis and transfer", SIGGRAPH 2001),
// is closed over the tile's height (p(H - 1) and p(0) are neighbours too when it repeats) and
// found by dynamic programming from each start. The rows are cut the same way after the
// columns. The region's position is the one whose two cuts cost least, counting too how far
// the wrap's own steps (a step of the data) exceed the data's mean step: the wrap goes where
// the texture changes no faster than it does on average.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/dataset.hpp"

namespace btfgmm {

struct SeamlessTileConfig {
  int width = 32, height = 32;
  // The overlaps ox, oy; 0: as many columns (rows) as the image allows, up to half the tile's
  // width (height). At least 2 (the cut needs a column of each strip).
  int overlap_x = 0, overlap_y = 0;
  // At most this many region positions are tried, spread evenly over those that fit.
  std::size_t max_positions = 4096;
  // Only the region at this (x, y): to make a recorded tile again (made_tile_of).
  std::optional<std::pair<int, int>> at;
  // Called with the fraction of the images read (1 last), from one thread at a time.
  std::function<void(double fraction)> progress;
  // Asked between batches of images; true stops with Error(kArgument) "stopped".
  std::function<bool()> stopped;
};

// What the cut costs, in levels: the RMS over the images and channels of the mismatch
// ||A - B|| along the cut's edges (half of M per edge), and the same of the texture's own
// neighbouring pixels, for scale.
struct SeamCutCost {
  double cut_levels = 0.0;        // mean over the cut edges of both cuts
  double neighbour_levels = 0.0;  // RMS step between neighbouring pixels of the data
  std::size_t edges = 0;
};

// A made tile: where each of its pixels is taken from, and how its cuts were found.
struct SeamlessTile {
  int width = 0, height = 0;
  Tile region;  // R in the source image
  int overlap_x = 0, overlap_y = 0;
  std::vector<int> column_cut;  // p(r), r < height: the first overlap column taken from A
  std::vector<int> row_cut;     // q(c), c < width: the first overlap row taken from A
  SeamCutCost cost;
  std::size_t positions = 0;  // region positions compared
  std::size_t images = 0;     // images the cost was summed over
  // The pixel map: each tile pixel the blend of up to 4 pixels of the region, weighted across
  // each cut over a feather of up to 4 pixels (a hard cut where the overlap is under 4 wide).
  PixelMap pixel_map(const std::string& description) const;
  // "seamless 32x32 tile cut from 12,3,48,48 (overlap 16x16)".
  std::string describe() const;
};

// Reads every image of `source` once, a batch at a time (memory: a batch of whole images,
// at most about 64 MB, and four cost maps of the image's size in doubles). Throws
// Error(kArgument) for a size the image cannot hold with an overlap of at least 2, naming
// the smallest image that would and the largest tile this one can give.
SeamlessTile cut_seamless_tile(const BtfSource& source, const SeamlessTileConfig& config);

// The made tile as a data set of its own (BtfSource::remapped).
BtfSource seamless_tile_source(const BtfSource& source, const SeamlessTile& tile);

// The tile a description (SeamlessTile::describe(), as a model's provenance records it) names,
// made again from `source`: the same region and overlap, so the same cut for the same data.
// Throws Error(kArgument) for a description that names no made tile.
SeamlessTile made_tile_again(const BtfSource& source, const std::string& description);

// The data a made tile's description (Btf::made_from, a checkpoint's or a provenance's record)
// names in `source`: that tile made again as a data set of its own, or for an empty description
// `source` itself. Throws as made_tile_again.
BtfSource made_tile_source(const BtfSource& source, const std::string& description);

// The made tile's pixel map as a small JSON document (seamless-tile.json beside its images):
// the source, the region, the overlaps, both cuts, their cost, and for each tile pixel (x, y),
// row-major, the source image's pixel it was taken from.
std::string seamless_tile_json(const SeamlessTile& tile, const BtfInfo& source);

// How visible the wrap of `tile` of `source` (empty: the whole image) is when it repeats, in
// the terms of the data's own steps, on `images` (light, view) images spread over the pairs of
// images whose view is at most 60 degrees from the normal (grazing views are foreshortened):
//   wrap ratio: the mean |step| across the wrap (last column to first, last row to first)
//     over the mean |step| between neighbouring interior columns / rows, averaged over both
//     directions; about 1: the wrap looks like any step inside the tile;
//   cut ratio (with a reference): the 99th percentile of the per-pixel mean |step| of the
//     tile repeated 2 x 2, averaged over the images, over the same of the reference's images:
//     a cut that shows as a line of large steps raises it above 1.
struct WrapStatistics {
  double median_ratio = 0.0, p90_ratio = 0.0;
  double cut_ratio = 0.0;  // 0 without a reference
  std::size_t images = 0;
};
WrapStatistics wrap_statistics(const BtfSource& source, const Tile& tile, std::size_t images = 64,
                               const BtfSource* reference = nullptr);

}  // namespace btfgmm
