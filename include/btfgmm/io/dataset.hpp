// BTF data sets on disk: discovering the images of a folder or a Bonn zip, reading a tile.
// Image names are parsed by btfgmm/io/image_names.hpp; the UTIA layout is written by
// btfgmm/io/utia.hpp (both included here).
//
// Names understood (angles in degrees, whole or with a fraction such as tl023.5):
//   UTIA, nested:  tv000_pv000/tl000_pl000_tv000_pv000.png   (also .jpg, .exr)
//   UTIA, flat:    tl000_pl000_tv000_pv000.png
//   Bonn UBO2003:  00008 tl000 pl000 tv030 pv030.jpg  (or with '_' separators), in folders
//                  or inside the material's .zip (read in place)
//   Bonn UBO2014:  one .btf file (!DFMF08FCR or !FMF12FCER, btfgmm/io/ubo_btf.hpp), known by its
//                  signature; its directions as the file lists them, its images decoded per tile
// The light set is every distinct (tl, pl), the view set every distinct (tv, pv), each sorted
// by theta then phi (for the 81-direction sets this is the UBO2003 order). Every (light,
// view) pair must have exactly one image, all of one size and kind.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/io/image_names.hpp"
#include "btfgmm/io/utia.hpp"

namespace btfgmm {

enum class Layout {
  kUtiaNested,  // one folder per view
  kUtiaFlat,    // all images in one folder
  kBonnFolder,  // Bonn names (leading image index), unpacked
  kBonnZip,     // Bonn names inside a .zip
  kUboBtf,      // one Bonn .btf file (a matrix factorisation), decoded per tile
};
std::string to_string(Layout l);

struct BtfInfo {
  std::filesystem::path path;
  Layout layout = Layout::kUtiaNested;
  DirectionSet lights, views;
  int width = 0, height = 0;
  SampleFormat format = SampleFormat::kLdr8;
  ImageFormat image_format = ImageFormat::kPng;
  std::uint64_t file_bytes = 0;     // bytes of the image files (compressed, on disk or in zip)
  std::uint64_t ignored_files = 0;  // files that are not images (e.g. a README), skipped
  // What a format says of itself beyond the above (a .btf file's kind, components, metadata
  // strings), as (name, value) pairs in the order to show them; empty for image folders.
  std::vector<std::pair<std::string, std::string>> details;
};

class UboBtf;

// An image made of another's pixels (a seamless tile cut from a larger region,
// btfgmm/measure/seamless_tile.hpp): pixel (x, y) of every image is the weighted sum over the
// taps of source[y * width + x] of the pixels (region.x + dx, region.y + dy) of the source
// image (the weights sum to 1; unused taps weigh 0), rounded to a level for 8-bit data.
struct PixelTap {
  std::uint16_t dx = 0, dy = 0;
  float weight = 0.0f;
};
struct PixelMap {
  int width = 0, height = 0;
  Tile region;
  std::vector<std::array<PixelTap, 4>> source;  // row-major
  std::string description;                      // what the map is, for messages and provenance
};

class BtfSource {
 public:
  // Discover the images at `path` (a folder, a .zip, or a Bonn .btf file), check that every (light,
  // view) pair has one image and that all images have one size and kind (reading headers only).
  // Throws Error naming the file(s) at fault and what is expected.
  static BtfSource open(const std::filesystem::path& path);

  const BtfInfo& info() const { return info_; }
  // The name of the image of a pair, relative to the folder (or the zip entry name).
  const std::string& image_name(std::size_t light, std::size_t view) const;

  // Read a tile of every image (an empty tile reads the whole image). Only the tile is kept
  // in memory (one decoded image per thread at a time; of a .btf file, the tile's factors). Throws
  // Error(kArgument) if the tile is not inside the image, Error(kFormat/kIo) if an image cannot be
  // read.
  Btf load(const Tile& tile = {}) const;

  // Read a tile of the images first .. last - 1 (light-major indices, as Btf::image_index)
  // without holding them: take(i, rgb) receives image i's tile (width * height * 3 floats,
  // row-major, RGB), from several threads at once, one decoded image per thread at a time.
  // `tile` must be inside the image (load checks it). Throws as load.
  using TileSink = std::function<void(std::size_t image, std::span<const float> rgb)>;
  void read_tiles(const Tile& tile, std::size_t first, std::size_t last,
                  const TileSink& take) const;

  // This data set with each image made by `map` (its region read, one per thread at a time):
  // its images are map.width x map.height; info().details names the map's description.
  // Throws Error(kArgument) if the region is not inside the image or a pixel lies outside it.
  BtfSource remapped(PixelMap map) const;
  // The map of a remapped source; null for one read as it is on disk.
  const PixelMap* pixel_map() const { return map_.get(); }

 private:
  void read_mapped_tiles(const Tile& tile, std::size_t first, std::size_t last,
                         const TileSink& take) const;

  static BtfSource open_ubo(const std::filesystem::path& path);  // io/dataset_ubo.cpp
  void read_ubo_tiles(const Tile& tile, std::size_t first, std::size_t last,
                      const TileSink& take) const;

  BtfInfo info_;
  std::vector<std::string> names_;             // light-major, as Btf::image_index
  std::shared_ptr<const UboBtf> ubo_;          // a .btf file's factors, else null
  std::shared_ptr<const BtfSource> original_;  // a remapped source's data as on disk
  std::shared_ptr<const PixelMap> map_;
};

}  // namespace btfgmm
