// The per-format codecs behind btfgmm/io/image.hpp: PNG and JPEG through stb (stb.cpp; PNG
// encoding through zlib, png_encode.cpp),
// OpenEXR through OpenEXR 3 (exr.cpp). They decode from memory and encode to memory;
// image.cpp tells the formats apart, reads and writes the files.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/io/image.hpp"

namespace btfgmm::detail {

inline constexpr std::array<std::uint8_t, 8> kPngMagic = {0x89, 'P',  'N',  'G',
                                                          '\r', '\n', 0x1a, '\n'};
inline constexpr std::array<std::uint8_t, 3> kJpegMagic = {0xff, 0xd8, 0xff};
inline constexpr std::array<std::uint8_t, 4> kExrMagic = {0x76, 0x2f, 0x31, 0x01};

// Images larger than this are refused before any allocation (a corrupt header must not make
// us allocate terabytes). BTF images are a few hundred pixels on a side.
inline constexpr int kMaxSide = limits::kMaxImageSide;
inline constexpr std::int64_t kMaxPixels = limits::kMaxImagePixels;

// Error(kFormat) unless w x h is a plausible image size (image.cpp).
void check_size(int w, int h, const std::string& name);
// Error(kArgument) unless the tile lies inside a w x h image (image.cpp).
void check_tile(const Tile& t, int w, int h, const std::string& name);

// ---- PNG and JPEG (stb.cpp) ----
ImageHeader stb_header(std::span<const std::uint8_t> bytes, ImageFormat f, const std::string& name);
Image stb_decode(std::span<const std::uint8_t> bytes, ImageFormat f, const std::string& name,
                 const Tile& rows);
// stb decodes what it can of a damaged PNG or JPEG; these check that the file is complete.
void check_png_complete(std::span<const std::uint8_t> bytes, const std::string& name);
void check_jpeg_complete(std::span<const std::uint8_t> bytes, const std::string& name);
// 8-bit levels of `rgb`: rounded (halves up) and clamped to 0..255; NaN becomes 0
// (png_encode.cpp).
std::vector<std::uint8_t> to_levels(std::span<const float> rgb);
// An 8-bit RGB PNG of `rgb` (levels as to_levels'), through zlib (png_encode.cpp).
std::vector<std::uint8_t> encode_png(int width, int height, std::span<const float> rgb,
                                     const std::string& name);
// A baseline JPEG of `rgb` (levels as encode_png's), at quality kJpegQuality.
inline constexpr int kJpegQuality = 95;
std::vector<std::uint8_t> encode_jpeg(int width, int height, std::span<const float> rgb,
                                      const std::string& name);

// ---- OpenEXR (exr.cpp) ----
ImageHeader exr_header(std::span<const std::uint8_t> bytes, const std::string& name);
Image exr_decode(std::span<const std::uint8_t> bytes, const std::string& name, const Tile& rows);
// A ZIP-compressed 32-bit float RGB OpenEXR image of `rgb`.
std::vector<std::uint8_t> encode_exr(int width, int height, std::span<const float> rgb,
                                     const std::string& name);

}  // namespace btfgmm::detail
