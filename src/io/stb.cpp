// PNG (8/16-bit) and JPEG through stb: structural checks that stb leaves out (a complete
// file, data enough for the size claimed, sane Huffman tables), decoding to float RGB with a
// tile cut out, and JPEG encoding (PNG encoding: png_encode.cpp).
#include <fmt/format.h>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "io/codecs.hpp"

namespace btfgmm::detail {
namespace {
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}

}  // namespace

// stb decodes what it can of a damaged PNG or JPEG and may return garbage for the rest; check
// structurally that the file is complete.
void check_png_complete(std::span<const std::uint8_t> bytes, const std::string& name) {
  // pos <= bytes.size() throughout: each length is compared with what is left after pos.
  std::size_t pos = kPngMagic.size();
  while (pos <= bytes.size() && bytes.size() - pos >= 12) {
    const std::uint64_t len = be32(&bytes[pos]);
    const bool iend = std::memcmp(&bytes[pos + 4], "IEND", 4) == 0;
    if (len > bytes.size() - pos - 12) break;
    if (iend) return;
    pos += 12 + std::size_t(len);
  }
  throw Error(Error::Kind::kFormat,
              fmt::format("{} is a truncated or corrupt PNG (its chunks end before the IEND "
                          "chunk); re-copy or re-export the file",
                          name));
}

void check_jpeg_complete(std::span<const std::uint8_t> bytes, const std::string& name) {
  // The end-of-image marker FF D9 must follow the last start-of-scan FF DA (entropy-coded data
  // never holds FF followed by D9 or DA: FF bytes are stuffed).
  std::size_t sos = 0;
  for (std::size_t i = bytes.size(); i-- > 1;)
    if (bytes[i - 1] == 0xff && bytes[i] == 0xda) {
      sos = i;
      break;
    }
  for (std::size_t i = sos + 1; i < bytes.size(); ++i)
    if (bytes[i - 1] == 0xff && bytes[i] == 0xd9) return;
  throw Error(Error::Kind::kFormat,
              fmt::format("{} is a truncated or corrupt JPEG (no end-of-image marker after "
                          "the image data); re-copy or re-export the file",
                          name));
}

namespace {

// Before decoding (and allocating for) the size a header claims: can the file hold that many
// pixels at all? A PNG's pixels are deflated in its IDAT chunks, which inflate to at most
// 1032 times their size; a JPEG codes every 8x8 block of its full-resolution component with
// at least one bit. A corrupt header claiming a huge image is refused here.
void check_data_holds(std::span<const std::uint8_t> bytes, ImageFormat f, int w, int h,
                      const std::string& name) {
  double need = 0.0, can = 0.0;
  std::string what;
  if (f == ImageFormat::kPng) {
    // The first IHDR (stb refuses a file without one) and the IDAT bytes, chunk by chunk.
    double bits_per_pixel = 0.0, idat = 0.0;
    bool ihdr = false;
    for (std::size_t pos = kPngMagic.size(); pos <= bytes.size() && bytes.size() - pos >= 12;) {
      const std::uint64_t len = be32(&bytes[pos]);
      if (len > bytes.size() - pos - 12) break;
      const std::uint8_t* type = &bytes[pos + 4];
      if (!ihdr && std::memcmp(type, "IHDR", 4) == 0 && len >= 13) {
        ihdr = true;
        const int depth = bytes[pos + 16], colour = bytes[pos + 17];
        const int channels = colour == 2 ? 3 : colour == 4 ? 2 : colour == 6 ? 4 : 1;
        bits_per_pixel = double(depth) * channels;
      }
      if (std::memcmp(type, "IDAT", 4) == 0) idat += double(len);
      pos += 12 + std::size_t(len);
    }
    if (!ihdr) return;  // stb reports it
    // At least ceil(bits / 8) bytes a row (interlaced images hold more: filter bytes).
    need = double(h) * std::ceil(double(w) * std::max(bits_per_pixel, 1.0) / 8.0);
    can = limits::kDeflateMaxRatio * idat + 1032.0;
    what = fmt::format("{} bytes of image data", idat);
  } else if (f == ImageFormat::kJpeg) {
    need = std::ceil(double(w) / 8.0) * std::ceil(double(h) / 8.0);  // blocks
    can = 8.0 * double(bytes.size());                                // bits
    what = fmt::format("{} bytes", bytes.size());
  }
  if (need > can)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims an image of {}x{} pixels, more than its {} can hold; "
                            "the file is corrupt or truncated, re-copy or re-export it",
                            name, w, h, what));
}

// The stb_image of Debian 12 (2022-09) trusts the code counts of a JPEG Huffman table (DHT):
// more than 256 codes overrun its tables, in the header reader as in the decoder (found by
// tests/fuzz/fuzz_image_set; checked upstream since stb_image 2.28). Every DHT segment is
// checked here, walking the markers as stb does, before stb sees the file.
void check_jpeg_huffman_tables(std::span<const std::uint8_t> bytes, const std::string& name) {
  const auto at = [&](std::size_t i) -> unsigned { return i < bytes.size() ? bytes[i] : 0u; };
  const auto be16 = [&](std::size_t i) { return at(i) << 8 | at(i + 1); };
  // pos < bytes.size() at each marker; a segment's length is at most 65535 and a table's
  // codes at most 256 (checked), so no sum below comes near the top of std::size_t.
  std::size_t pos = 2;  // after SOI
  while (pos < bytes.size()) {
    if (bytes[pos] != 0xff) {  // stb skips bytes until a marker
      ++pos;
      continue;
    }
    while (pos < bytes.size() && bytes[pos] == 0xff) ++pos;  // fill bytes
    if (pos >= bytes.size()) return;
    const unsigned m = bytes[pos++];
    if (m == 0x00 || m == 0x01 || m == 0xd8 || m == 0xd9 || (m >= 0xd0 && m <= 0xd7)) continue;
    const std::size_t length = be16(pos);  // includes its own two bytes
    if (m == 0xc4) {
      std::size_t p = pos + 2;
      const std::size_t end = pos + length;
      while (p < end && p < bytes.size()) {
        std::size_t n = 0;
        for (std::size_t i = 0; i < 16; ++i) n += at(p + 1 + i);
        if (n > 256)
          throw Error(Error::Kind::kFormat,
                      fmt::format("{} is a corrupt JPEG (a Huffman table holds {} codes, at most "
                                  "256 are possible); re-copy or re-export the file",
                                  name, n));
        p += 17 + n;
      }
    }
    pos += std::max<std::size_t>(length, 2);
    if (m == 0xda)  // entropy-coded data up to the next marker (FF, then not 00 or RSTn)
      while (pos + 1 < bytes.size() && !(bytes[pos] == 0xff && bytes[pos + 1] != 0x00 &&
                                         !(bytes[pos + 1] >= 0xd0 && bytes[pos + 1] <= 0xd7)))
        ++pos;
  }
}

int checked_len(std::span<const std::uint8_t> bytes, const std::string& name) {
  if (bytes.size() > std::size_t(std::numeric_limits<int>::max()))
    throw Error(
        Error::Kind::kFormat,
        fmt::format("{} is {} bytes, too large for a PNG or JPEG BTF image", name, bytes.size()));
  return static_cast<int>(bytes.size());
}

// stb's failure reason is thread-local in this stb (STBI_THREAD_LOCAL), so reading it right
// after the failing call on the same thread is safe under OpenMP.
std::string stb_reason() {
  const char* r = stbi_failure_reason();
  return r ? r : "unknown reason";
}

}  // namespace

ImageHeader stb_header(std::span<const std::uint8_t> bytes, ImageFormat f,
                       const std::string& name) {
  const int len = checked_len(bytes, name);
  if (f == ImageFormat::kJpeg) check_jpeg_huffman_tables(bytes, name);
  int w = 0, h = 0, comp = 0;
  if (!stbi_info_from_memory(bytes.data(), len, &w, &h, &comp))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is a corrupt or truncated {} (stb_image: {}); re-copy or "
                            "re-export the file",
                            name, to_string(f), stb_reason()));
  check_size(w, h, name);
  ImageHeader hdr;
  hdr.width = w;
  hdr.height = h;
  hdr.format = (f == ImageFormat::kPng && stbi_is_16_bit_from_memory(bytes.data(), len))
                   ? SampleFormat::kLdr16
                   : SampleFormat::kLdr8;
  return hdr;
}

Image stb_decode(std::span<const std::uint8_t> bytes, ImageFormat f, const std::string& name,
                 const Tile& rows) {
  const ImageHeader hdr = stb_header(bytes, f, name);
  const Tile t = rows.or_whole(hdr.width, hdr.height);
  check_tile(t, hdr.width, hdr.height, name);
  if (f == ImageFormat::kPng) check_png_complete(bytes, name);
  if (f == ImageFormat::kJpeg) check_jpeg_complete(bytes, name);
  check_data_holds(bytes, f, hdr.width, hdr.height, name);
  // stb's decoded image (8 or 16 bits a sample) and the tile as floats.
  const double sample_bytes = hdr.format == SampleFormat::kLdr16 ? 2.0 : 1.0;
  limits::check_memory(
      double(hdr.width) * hdr.height * 3.0 * sample_bytes + double(t.width) * t.height * 12.0,
      fmt::format("decoding {} ({}x{} pixels)", name, hdr.width, hdr.height),
      "the file is corrupt, or too large for this machine", Error::Kind::kFormat);

  const int len = static_cast<int>(bytes.size());
  int w = 0, h = 0, comp = 0;
  Image img;
  img.width = t.width;
  img.height = t.height;
  img.format = hdr.format;
  img.rgb.resize(std::size_t(t.width) * std::size_t(t.height) * 3);
  auto crop = [&](const auto* pixels) {
    for (int y = 0; y < t.height; ++y) {
      const auto* src = pixels + (std::size_t(t.y + y) * std::size_t(w) + std::size_t(t.x)) * 3;
      float* dst = img.rgb.data() + std::size_t(y) * std::size_t(t.width) * 3;
      for (std::size_t i = 0; i < std::size_t(t.width) * 3; ++i) {
        if constexpr (sizeof(*src) == 1)
          dst[i] = static_cast<float>(src[i]);
        else
          dst[i] = static_cast<float>(src[i]) / 257.0f;
      }
    }
  };
  if (hdr.format == SampleFormat::kLdr16) {
    std::unique_ptr<stbi_us, void (*)(void*)> px(
        stbi_load_16_from_memory(bytes.data(), len, &w, &h, &comp, 3), stbi_image_free);
    if (!px)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} is a corrupt or truncated PNG (stb_image: {}); re-copy or "
                              "re-export the file",
                              name, stb_reason()));
    if (w != hdr.width || h != hdr.height)
      throw Error(Error::Kind::kFormat, fmt::format("{}: inconsistent image size", name));
    crop(px.get());
  } else {
    std::unique_ptr<stbi_uc, void (*)(void*)> px(
        stbi_load_from_memory(bytes.data(), len, &w, &h, &comp, 3), stbi_image_free);
    if (!px)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} is a corrupt or truncated {} (stb_image: {}); re-copy or "
                              "re-export the file",
                              name, to_string(f), stb_reason()));
    if (w != hdr.width || h != hdr.height)
      throw Error(Error::Kind::kFormat, fmt::format("{}: inconsistent image size", name));
    crop(px.get());
  }
  return img;
}

namespace {

void append_bytes(void* ctx, void* data, int size) {
  auto* v = static_cast<std::vector<std::uint8_t>*>(ctx);
  const auto* p = static_cast<const std::uint8_t*>(data);
  v->insert(v->end(), p, p + size);
}

}  // namespace

std::vector<std::uint8_t> encode_jpeg(int width, int height, std::span<const float> rgb,
                                      const std::string& name) {
  const std::vector<std::uint8_t> px = to_levels(rgb);
  std::vector<std::uint8_t> out;
  if (!stbi_write_jpg_to_func(append_bytes, &out, width, height, 3, px.data(), kJpegQuality))
    throw Error(Error::Kind::kIo, fmt::format("cannot write {}: JPEG encoding failed", name));
  return out;
}

}  // namespace btfgmm::detail
