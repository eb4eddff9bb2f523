// Single images in and out: PNG (8/16-bit), JPEG, OpenEXR. Used by the BTF readers and
// writers and by everything that writes a picture.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

enum class ImageFormat { kPng, kJpeg, kExr };
// "PNG", "JPEG", "OpenEXR".
std::string to_string(ImageFormat f);

// The format a file name's extension promises (.png, .jpg/.jpeg, .exr, any case), if any.
std::optional<ImageFormat> image_format_from_name(const std::string& name);
// The format the bytes say they are (magic numbers), if any.
std::optional<ImageFormat> image_format_from_bytes(std::span<const std::uint8_t> bytes);

// An RGB float image, row-major, RGB interleaved, in the scale of btf.hpp.
struct Image {
  int width = 0, height = 0;
  SampleFormat format = SampleFormat::kLdr8;
  std::vector<float> rgb;
};

// What a file's header says, without decoding the pixels.
struct ImageHeader {
  int width = 0, height = 0;
  SampleFormat format = SampleFormat::kLdr8;
};

// Decode an image held in memory. `name` is used in error messages and to check that the
// extension matches the contents (a JPEG named .png is an error). Grey and RGBA inputs become
// RGB. NaN or infinite values in an EXR are an error. If `rows` is not empty, only the rows
// [rows.y, rows.y + rows.height) and columns [rows.x, rows.x + rows.width) are kept.
Image decode_image(std::span<const std::uint8_t> bytes, const std::string& name,
                   const Tile& rows = {});
ImageHeader decode_image_header(std::span<const std::uint8_t> bytes, const std::string& name);

Image read_image(const std::filesystem::path& path, const Tile& rows = {});
ImageHeader read_image_header(const std::filesystem::path& path);

// Write an image. PNG and JPEG: 8-bit, values rounded and clamped to 0..255 (JPEG at quality
// 95). EXR: 32-bit float RGB, exact. The file is written under a temporary name and renamed,
// so a failed write never leaves a broken file under `path`.
void write_png(const std::filesystem::path& path, int width, int height,
               std::span<const float> rgb);
void write_jpeg(const std::filesystem::path& path, int width, int height,
                std::span<const float> rgb);
void write_exr(const std::filesystem::path& path, int width, int height,
               std::span<const float> rgb);

// The format an output file's extension names (.png, .jpg or .jpeg, .exr, any case); throws
// Error(kArgument) naming the file and the extensions written otherwise. Check an output name
// with it before any work.
ImageFormat output_image_format(const std::filesystem::path& path);
// An image in the format its name's extension names, its values as they are (levels for
// PNG and JPEG, the floats themselves for EXR); Error(kArgument) as output_image_format.
void write_image(const std::filesystem::path& path, const Image& image);
// A picture of display levels (sRGB, 0-255, as btfgmm's renderings are) in the format its
// name's extension names: PNG or JPEG levels, or OpenEXR linear values (the levels decoded
// from sRGB, so that a viewer shows the same picture).
void write_picture(const std::filesystem::path& path, int width, int height,
                   std::span<const float> levels);

}  // namespace btfgmm
