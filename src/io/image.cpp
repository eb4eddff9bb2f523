// Single images in and out: which format a file holds, and the entry points that read and
// write files. The codecs (PNG and JPEG through stb, OpenEXR through OpenEXR 3) work in memory
// (files are read whole, zip entries are inflated), so one code path serves folders and
// archives. Errors are btfgmm::Error naming the file.
#include "btfgmm/io/image.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <system_error>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "io/codecs.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using detail::kExrMagic;
using detail::kJpegMagic;
using detail::kPngMagic;

// read_image_header reads this much of a file first; PNG and EXR headers and nearly every
// JPEG SOF lie within it.
constexpr std::size_t kHeaderPrefix = 64 * 1024;

const char* format_extension(ImageFormat f) {
  switch (f) {
    case ImageFormat::kPng:
      return ".png";
    case ImageFormat::kJpeg:
      return ".jpg";
    case ImageFormat::kExr:
      return ".exr";
  }
  return "";
}

// Which format the bytes hold; throws when they hold none, or not the one the name promises.
ImageFormat detect_format(std::span<const std::uint8_t> bytes, const std::string& name) {
  const auto by_name = image_format_from_name(name);
  const auto by_bytes = image_format_from_bytes(bytes);
  if (bytes.empty())
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is empty (0 bytes); replace it with a valid PNG, JPEG or "
                            "OpenEXR image",
                            name));
  if (!by_bytes)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is not a PNG, JPEG or OpenEXR image (its first bytes match "
                            "none of them); the file is corrupt or of another kind",
                            name));
  if (by_name && *by_name != *by_bytes)
    throw Error(
        Error::Kind::kFormat,
        fmt::format("{} holds {} data but its name says {}; rename it to {} or "
                    "re-encode it",
                    name, to_string(*by_bytes), to_string(*by_name), format_extension(*by_bytes)));
  return *by_bytes;
}

}  // namespace

namespace detail {

void check_size(int w, int h, const std::string& name) {
  if (w < 1 || h < 1 || w > kMaxSide || h > kMaxSide ||
      std::int64_t(w) * std::int64_t(h) > kMaxPixels)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims an image size of {}x{}, which is empty or too large "
                            "(at most {} pixels a side, {} pixels); the file is corrupt",
                            name, w, h, kMaxSide, kMaxPixels));
}

void check_tile(const Tile& t, int w, int h, const std::string& name) {
  if (t.x < 0 || t.y < 0 || std::int64_t(t.x) + t.width > w || std::int64_t(t.y) + t.height > h)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile x={} y={} {}x{} is not inside {} (the image is {}x{}); "
                            "give a tile with 0 <= x, x + width <= {}, 0 <= y, y + height <= {}",
                            t.x, t.y, t.width, t.height, name, w, h, w, h));
}

}  // namespace detail

namespace {

// ---- files -----------------------------------------------------------------------------

// An image file, read whole.
std::vector<std::uint8_t> read_image_file(const fs::path& path) {
  return read_whole_file(path, "image", "it is not a BTF image; move it out of the folder",
                         Error::Kind::kIo);
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

[[noreturn]] void cannot_read(const fs::path& path, int err) {
  throw Error(Error::Kind::kIo, fmt::format("cannot read {}: {}", path.string(),
                                            err ? std::strerror(err)
                                                : "the file ended early (is it being "
                                                  "written?)"));
}

// An image file opened for reading parts of it.
File open_for_reading(const fs::path& path) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot open {}: {}", path.string(), std::strerror(err)));
  }
  return f;
}

// `n` bytes from `offset` (which the caller knows the file holds).
std::vector<std::uint8_t> read_part(std::FILE* f, const fs::path& path, std::uint64_t offset,
                                    std::size_t n) {
  std::vector<std::uint8_t> bytes(n);
  if (std::fseek(f, static_cast<long>(offset), SEEK_SET) != 0 ||
      std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size())
    cannot_read(path, std::ferror(f) ? errno : 0);
  return bytes;
}

// The header of a large file from its first bytes, when they settle it: for PNG and JPEG the
// file's last bytes must also end the image (IEND, EOI), so a truncated file is caught.
std::optional<ImageHeader> header_from_parts(std::FILE* f, const fs::path& path,
                                             std::uint64_t size) {
  try {
    const auto prefix = read_part(f, path, 0, kHeaderPrefix);
    const ImageHeader hdr = decode_image_header(prefix, path.string());
    const ImageFormat fmt = *image_format_from_bytes(prefix);
    if (fmt == ImageFormat::kExr) return hdr;
    const auto tail = read_part(f, path, size - 12, 12);
    if (fmt == ImageFormat::kPng && std::memcmp(&tail[4], "IEND", 4) == 0) return hdr;
    if (fmt == ImageFormat::kJpeg && tail[10] == 0xff && tail[11] == 0xd9) return hdr;
  } catch (const Error& e) {
    if (e.kind() == Error::Kind::kIo) throw;
  }
  return std::nullopt;
}

void check_write_args(const fs::path& path, int width, int height, std::span<const float> rgb) {
  if (width < 1 || height < 1 || rgb.size() != std::size_t(width) * std::size_t(height) * 3)
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write {}: an image of {}x{} pixels needs {} floats, got {}",
                            path.string(), width, height,
                            std::size_t(std::max(width, 0)) * std::size_t(std::max(height, 0)) * 3,
                            rgb.size()));
}

}  // namespace

std::string to_string(ImageFormat f) {
  switch (f) {
    case ImageFormat::kPng:
      return "PNG";
    case ImageFormat::kJpeg:
      return "JPEG";
    case ImageFormat::kExr:
      return "OpenEXR";
  }
  return "?";
}

std::optional<ImageFormat> image_format_from_name(const std::string& name) {
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const std::string ext = lower(name.substr(dot + 1));
  if (ext == "png") return ImageFormat::kPng;
  if (ext == "jpg" || ext == "jpeg") return ImageFormat::kJpeg;
  if (ext == "exr") return ImageFormat::kExr;
  return std::nullopt;
}

std::optional<ImageFormat> image_format_from_bytes(std::span<const std::uint8_t> bytes) {
  auto starts = [&](const auto& magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  if (starts(kPngMagic)) return ImageFormat::kPng;
  if (starts(kJpegMagic)) return ImageFormat::kJpeg;
  if (starts(kExrMagic)) return ImageFormat::kExr;
  return std::nullopt;
}

Image decode_image(std::span<const std::uint8_t> bytes, const std::string& name, const Tile& rows) {
  const ImageFormat f = detect_format(bytes, name);
  if (f == ImageFormat::kExr) return detail::exr_decode(bytes, name, rows);
  return detail::stb_decode(bytes, f, name, rows);
}

ImageHeader decode_image_header(std::span<const std::uint8_t> bytes, const std::string& name) {
  const ImageFormat f = detect_format(bytes, name);
  if (f == ImageFormat::kExr) return detail::exr_header(bytes, name);
  return detail::stb_header(bytes, f, name);
}

Image read_image(const fs::path& path, const Tile& rows) {
  return decode_image(read_image_file(path), path.string(), rows);
}

ImageHeader read_image_header(const fs::path& path) {
  // Headers only: the first 64 KiB and the last bytes. When that does not settle it (a header
  // further in, trailing bytes after the image), or the file is small, the whole file.
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (!ec && size > kHeaderPrefix) {
    const File f = open_for_reading(path);
    if (const auto hdr = header_from_parts(f.get(), path, size)) return *hdr;
  }
  const auto bytes = read_image_file(path);
  const std::string name = path.string();
  const ImageHeader hdr = decode_image_header(bytes, name);
  const ImageFormat fmt = *image_format_from_bytes(bytes);
  if (fmt == ImageFormat::kPng) detail::check_png_complete(bytes, name);
  if (fmt == ImageFormat::kJpeg) detail::check_jpeg_complete(bytes, name);
  return hdr;
}

void write_png(const fs::path& path, int width, int height, std::span<const float> rgb) {
  check_write_args(path, width, height, rgb);
  write_file_atomically(path, detail::encode_png(width, height, rgb, path.string()), "image");
}

void write_exr(const fs::path& path, int width, int height, std::span<const float> rgb) {
  check_write_args(path, width, height, rgb);
  write_file_atomically(path, detail::encode_exr(width, height, rgb, path.string()), "image");
}

void write_jpeg(const fs::path& path, int width, int height, std::span<const float> rgb) {
  check_write_args(path, width, height, rgb);
  write_file_atomically(path, detail::encode_jpeg(width, height, rgb, path.string()), "image");
}

ImageFormat output_image_format(const fs::path& path) {
  if (const auto f = image_format_from_name(path.filename().string())) return *f;
  throw Error(Error::Kind::kArgument,
              fmt::format("cannot write the image '{}': its extension names no format btfgmm "
                          "writes; give a name ending in .png, .jpg (or .jpeg) or .exr",
                          path.string()));
}

void write_image(const fs::path& path, const Image& image) {
  switch (output_image_format(path)) {
    case ImageFormat::kPng:
      return write_png(path, image.width, image.height, image.rgb);
    case ImageFormat::kJpeg:
      return write_jpeg(path, image.width, image.height, image.rgb);
    case ImageFormat::kExr:
      return write_exr(path, image.width, image.height, image.rgb);
  }
}

void write_picture(const fs::path& path, int width, int height, std::span<const float> levels) {
  const ImageFormat f = output_image_format(path);
  if (f == ImageFormat::kPng) return write_png(path, width, height, levels);
  if (f == ImageFormat::kJpeg) return write_jpeg(path, width, height, levels);
  // sRGB levels to linear values (IEC 61966-2-1), levels above 255 along the same curve.
  std::vector<float> linear(levels.size());
  for (std::size_t i = 0; i < levels.size(); ++i) {
    const double e = std::max(0.0, double(levels[i]) / 255.0);
    linear[i] = float(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
  }
  write_exr(path, width, height, linear);
}

}  // namespace btfgmm
