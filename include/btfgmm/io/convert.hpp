// Converting any data set btfgmm reads (image folders, Bonn zips, Bonn .btf files) to the
// nested UTIA layout, image by image: only one image's tile per thread is held at a time (of a
// .btf file, also the tile's factors), so a whole set converts in memory proportional to a tile.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"

namespace btfgmm {

struct ConvertOptions {
  // PNG or EXR; default: EXR for HDR data, PNG for 8- and 16-bit data. JPEG is refused.
  std::optional<ImageFormat> format;
  // PNG of HDR data: level = 255 * exposure * value, linear (no sRGB curve), rounded and
  // clamped to 0..255. PNG of 8/16-bit data: level = exposure * value. EXR: ignored (the linear
  // values as decoded). Must be finite and > 0.
  double exposure = 1.0;
  // Called with the fraction of the images written, from one thread at a time.
  std::function<void(double fraction)> progress;
  // Asked between images; true stops the conversion with Error(kArgument) "stopped"; the images
  // written so far stay whole (each is written atomically).
  std::function<bool()> stopped;
};

struct ConvertResult {
  std::size_t images = 0;
  ImageFormat format = ImageFormat::kPng;
  Tile tile;
  std::string note;  // what conversion.txt holds: source, tile, format, exposure
};

// What a conversion will write, known before it starts: the images, their format and tile,
// and the bytes of their pixels before compression (PNG: 3 per pixel; EXR: 12, 32-bit float),
// a bound the files stay near (PNG compresses, EXR adds a header of a few hundred bytes).
struct ConvertPlan {
  std::size_t images = 0;
  ImageFormat format = ImageFormat::kPng;
  Tile tile;
  std::uint64_t pixel_bytes = 0;
};

// Throws as convert_to_utia for a bad format or exposure (naming `folder`).
ConvertPlan plan_conversion(const BtfSource& source, const Tile& tile,
                            const std::filesystem::path& folder, const ConvertOptions& options);

// Write the tile (empty: the whole image) of every image of `source` under `folder` (created if
// needed) as tvTTT_pvPPP/tlTTT_plPPP_tvTTT_pvPPP.png or .exr, and a conversion.txt that states
// the source, the tile, the format and the exposure. Throws Error for a tile outside the images,
// a bad exposure or format, or an image that cannot be read or written.
ConvertResult convert_to_utia(const BtfSource& source, const Tile& tile,
                              const std::filesystem::path& folder, const ConvertOptions& options);

}  // namespace btfgmm
