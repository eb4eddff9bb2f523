// What a file holds, by its magic numbers or its name (include/btfgmm/io/file_kind.hpp).
#include "btfgmm/io/file_kind.hpp"

#include <array>
#include <cstring>

#include "btfgmm/core/text.hpp"
#include "btfgmm/io/image.hpp"

namespace btfgmm {
namespace {

struct Magic {
  std::size_t offset;
  std::string_view bytes;
  FileKind kind;
};

using C = FileKind::Class;

// Magic numbers of the common formats a user may give by mistake (from each format's
// specification; tar's "ustar" is at byte 257 of its first header).
const std::array<Magic, 17>& magics() {
  using namespace std::string_view_literals;
  static const std::array<Magic, 17> m{{
      {0,
       "\x89"
       "BTFCKP\n"sv,
       {C::kCheckpoint, "a btfgmm checkpoint of a fit"}},
      {0, "\x1f\x8b"sv, {C::kArchive, "a gzip archive"}},
      {0, "BZh"sv, {C::kArchive, "a bzip2 archive"}},
      {0,
       "\xfd"
       "7zXZ\0"sv,
       {C::kArchive, "an xz archive"}},
      {0, "\x28\xb5\x2f\xfd"sv, {C::kArchive, "a zstd archive"}},
      {0, "7z\xbc\xaf\x27\x1c"sv, {C::kArchive, "a 7-Zip archive"}},
      {0, "Rar!\x1a\x07"sv, {C::kArchive, "a RAR archive"}},
      {257, "ustar"sv, {C::kArchive, "a tar archive"}},
      {0, "PK\x03\x04"sv, {C::kZip, "a zip archive"}},
      {0, "PK\x05\x06"sv, {C::kZip, "a zip archive"}},
      {0, "II*\0"sv, {C::kImage, "a TIFF image"}},
      {0, "MM\0*"sv, {C::kImage, "a TIFF image"}},
      {0, "BM"sv, {C::kImage, "a BMP image"}},
      {0, "GIF8"sv, {C::kImage, "a GIF image"}},
      {0, "#?RADIANCE"sv, {C::kImage, "a Radiance HDR image"}},
      {0, "#?RGBE"sv, {C::kImage, "a Radiance HDR image"}},
      {0, "%PDF-"sv, {C::kOther, "a PDF document"}},
  }};
  return m;
}

bool at(std::span<const std::uint8_t> head, std::size_t offset, std::string_view bytes) {
  return head.size() >= offset + bytes.size() &&
         std::memcmp(head.data() + offset, bytes.data(), bytes.size()) == 0;
}

// Text: no NUL and no control bytes other than tab, line feed, carriage return and form feed
// in the first bytes (UTF-8 passes: its bytes above 0x7f are not control bytes).
bool is_text(std::span<const std::uint8_t> head) {
  if (head.empty()) return false;
  for (std::size_t i = 0; i < head.size() && i < 512; ++i) {
    const std::uint8_t c = head[i];
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f') return false;
    if (c == 0x7f) return false;
  }
  return true;
}

}  // namespace

std::optional<FileKind> identify_file(std::span<const std::uint8_t> head) {
  if (const auto image = image_format_from_bytes(head)) {
    switch (*image) {
      case ImageFormat::kPng:
        return FileKind{C::kImage, "a PNG image"};
      case ImageFormat::kJpeg:
        return FileKind{C::kImage, "a JPEG image"};
      case ImageFormat::kExr:
        return FileKind{C::kImage, "an OpenEXR image"};
    }
  }
  if (at(head, 0, "RIFF") && at(head, 8, "WEBP")) return FileKind{C::kImage, "a WebP image"};
  for (const Magic& m : magics())
    if (at(head, m.offset, m.bytes)) return m.kind;
  if (is_text(head)) return FileKind{C::kOther, "a text file"};
  return std::nullopt;
}

std::optional<std::string_view> unread_image_format_from_name(const std::string& name) {
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const std::string ext = lower(name.substr(dot + 1));
  struct Ext {
    std::string_view ext, format;
  };
  static constexpr std::array<Ext, 14> known{{{"tif", "TIFF"},
                                              {"tiff", "TIFF"},
                                              {"bmp", "BMP"},
                                              {"gif", "GIF"},
                                              {"webp", "WebP"},
                                              {"hdr", "Radiance HDR"},
                                              {"pic", "Radiance HDR"},
                                              {"ppm", "PNM"},
                                              {"pgm", "PNM"},
                                              {"pfm", "PFM"},
                                              {"tga", "TGA"},
                                              {"jp2", "JPEG 2000"},
                                              {"heic", "HEIF"},
                                              {"avif", "AVIF"}}};
  for (const Ext& e : known)
    if (e.ext == ext) return e.format;
  return std::nullopt;
}

bool is_model_file_start(std::span<const std::uint8_t> head) {
  using namespace std::string_view_literals;
  return at(head, 0,
            "\x89"
            "BTFGMM\n"sv);
}

}  // namespace btfgmm
