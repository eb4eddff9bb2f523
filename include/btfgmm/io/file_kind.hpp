// What a file holds when it is not what btfgmm expected there: told by its first bytes (magic
// numbers) or by its name, so that a message can say "c.tar.gz is a gzip archive" or "these
// are TIFF images" instead of only "not a model file" or "no images found".
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace btfgmm {

struct FileKind {
  enum class Class {
    kArchive,     // gzip, bzip2, xz, zstd, 7z, tar, RAR: to be extracted
    kZip,         // a zip archive (a Bonn BTF is one)
    kImage,       // one image (PNG, JPEG, OpenEXR, TIFF, BMP, ...)
    kCheckpoint,  // btfgmm's own checkpoint of an unfinished fit (model/checkpoint.hpp)
    kOther,       // a document or text
  };
  Class kind = Class::kOther;
  std::string_view what;  // "a gzip archive", "a PNG image", "a text file"
};

// The kind of contents whose first bytes are `head` (at least the first 512 bytes of the file,
// or all of it), among common archives, images, documents and text; nullopt when they match
// none (a btfgmm file matches none).
std::optional<FileKind> identify_file(std::span<const std::uint8_t> head);

// Whether `head` starts with the magic bytes of a btfgmm model file (docs/FORMAT.md): for the
// messages of the readers of data, which a model given in its place should name as a model.
bool is_model_file_start(std::span<const std::uint8_t> head);

// An image format btfgmm does not read, from a file name's extension: "TIFF" for .tif or
// .tiff, "BMP", "GIF", "WebP", "Radiance HDR", "PNM", "TGA", "JPEG 2000", "HEIF", any case.
std::optional<std::string_view> unread_image_format_from_name(const std::string& name);

}  // namespace btfgmm
