// Single images in and out: PNG (8/16-bit) and JPEG through stb, OpenEXR through OpenEXR 3.
// Everything is decoded from memory (files are read whole, zip entries are inflated), so one
// code path serves folders and archives. Errors are btfgmm::Error naming the file.
#include "btfgmm/io/image.hpp"

#include <fmt/format.h>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <OpenEXR/Iex.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <system_error>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

constexpr std::array<std::uint8_t, 8> kPngMagic = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr std::array<std::uint8_t, 3> kJpegMagic = {0xff, 0xd8, 0xff};
constexpr std::array<std::uint8_t, 4> kExrMagic = {0x76, 0x2f, 0x31, 0x01};

// Images larger than this are refused before any allocation (a corrupt header must not make
// us allocate terabytes). BTF images are a few hundred pixels on a side.
constexpr int kMaxSide = limits::kMaxImageSide;
constexpr std::int64_t kMaxPixels = limits::kMaxImagePixels;

// OpenEXR images are decoded this many scanlines at a time.
constexpr int kExrBand = 64;

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

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}

// stb decodes what it can of a damaged PNG or JPEG and may return garbage for the rest; check
// structurally that the file is complete.
void check_png_complete(std::span<const std::uint8_t> bytes, const std::string& name) {
  std::size_t pos = kPngMagic.size();
  while (pos + 12 <= bytes.size()) {
    const std::uint64_t len = be32(&bytes[pos]);
    const bool iend = std::memcmp(&bytes[pos + 4], "IEND", 4) == 0;
    if (pos + 12 + len > bytes.size()) break;
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
    for (std::size_t pos = kPngMagic.size(); pos + 12 <= bytes.size();) {
      const std::uint64_t len = be32(&bytes[pos]);
      if (pos + 12 + len > bytes.size()) break;
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
  const Tile t = rows.empty() ? Tile{0, 0, hdr.width, hdr.height} : rows;
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

// ---- OpenEXR ---------------------------------------------------------------------------

class MemoryIStream final : public Imf::IStream {
 public:
  MemoryIStream(std::span<const std::uint8_t> bytes, const std::string& name)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}

  bool read(char c[], int n) override {
    if (n < 0 || pos_ + std::uint64_t(n) > bytes_.size())
      throw Iex::InputExc("unexpected end of file");
    std::memcpy(c, bytes_.data() + pos_, std::size_t(n));
    pos_ += std::uint64_t(n);
    return pos_ < bytes_.size();
  }
  std::uint64_t tellg() override { return pos_; }
  void seekg(std::uint64_t pos) override { pos_ = pos; }
  void clear() override {}

 private:
  std::span<const std::uint8_t> bytes_;
  std::uint64_t pos_ = 0;
};

class MemoryOStream final : public Imf::OStream {
 public:
  explicit MemoryOStream(const std::string& name) : Imf::OStream(name.c_str()) {}

  void write(const char c[], int n) override {
    if (n <= 0) return;
    if (pos_ + std::size_t(n) > bytes_.size()) bytes_.resize(pos_ + std::size_t(n));
    std::memcpy(bytes_.data() + pos_, c, std::size_t(n));
    pos_ += std::size_t(n);
  }
  std::uint64_t tellp() override { return pos_; }
  void seekp(std::uint64_t pos) override { pos_ = std::size_t(pos); }

  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
  std::size_t pos_ = 0;
};

struct ExrLayout {
  int width = 0, height = 0;
  Imath::Box2i data_window;
  bool grey = false;  // one Y channel instead of R, G, B
};

ExrLayout exr_layout(const Imf::Header& header, const std::string& name) {
  ExrLayout l;
  l.data_window = header.dataWindow();
  const auto& dw = l.data_window;
  const std::int64_t w = std::int64_t(dw.max.x) - dw.min.x + 1;
  const std::int64_t h = std::int64_t(dw.max.y) - dw.min.y + 1;
  if (w < 1 || h < 1 || w > kMaxSide || h > kMaxSide)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} has a data window of {}x{} pixels, which is empty or too "
                            "large; the file is corrupt",
                            name, w, h));
  check_size(static_cast<int>(w), static_cast<int>(h), name);
  l.width = static_cast<int>(w);
  l.height = static_cast<int>(h);

  const Imf::ChannelList& ch = header.channels();
  const bool rgb = ch.findChannel("R") && ch.findChannel("G") && ch.findChannel("B");
  l.grey = !rgb && ch.findChannel("Y");
  if (!rgb && !l.grey) {
    std::string names;
    for (auto it = ch.begin(); it != ch.end(); ++it)
      names += (names.empty() ? "" : ", ") + std::string(it.name());
    throw Error(Error::Kind::kFormat,
                fmt::format("{} has no R, G, B channels and no Y channel (it has: {}); "
                            "write the image with R, G, B channels",
                            name, names.empty() ? "none" : names));
  }
  for (const char* c :
       rgb ? std::vector<const char*>{"R", "G", "B"} : std::vector<const char*>{"Y"}) {
    const Imf::Channel* channel = ch.findChannel(c);
    if (channel->xSampling != 1 || channel->ySampling != 1)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{}: channel {} is subsampled ({}x{}); only full-resolution "
                              "channels are supported, re-export the image without "
                              "subsampling",
                              name, c, channel->xSampling, channel->ySampling));
  }
  return l;
}

[[noreturn]] void rethrow_exr(const std::string& name, const char* what) {
  throw Error(Error::Kind::kFormat,
              fmt::format("{} is not a readable OpenEXR image (OpenEXR: {}); the file is "
                          "corrupt or truncated, re-copy or re-export it",
                          name, what));
}

ImageHeader exr_header(std::span<const std::uint8_t> bytes, const std::string& name) {
  try {
    MemoryIStream stream(bytes, name);
    // Header::readFrom expects the magic number and version field already read.
    std::array<char, 8> start{};
    stream.read(start.data(), 8);
    int version = 0;
    for (int i = 3; i >= 0; --i)
      version = int(unsigned(version) << 8 | std::uint8_t(start[std::size_t(4 + i)]));
    if ((version & 0xff) != 2)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} is OpenEXR version {}, not 2; re-export it with a current "
                              "OpenEXR",
                              name, version & 0xff));
    Imf::Header header;
    header.readFrom(stream, version);
    const ExrLayout l = exr_layout(header, name);
    return {l.width, l.height, SampleFormat::kHdr};
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    rethrow_exr(name, e.what());
  }
}

Image exr_decode(std::span<const std::uint8_t> bytes, const std::string& name, const Tile& rows) {
  // The header first: OpenEXR sizes its tables by the data window, so an absurd one is
  // refused before InputFile allocates for it.
  const ImageHeader hdr = exr_header(bytes, name);
  {
    const Tile t = rows.empty() ? Tile{0, 0, hdr.width, hdr.height} : rows;
    check_tile(t, hdr.width, hdr.height, name);
    limits::check_memory(double(t.width) * t.height * 12.0 + double(hdr.width) * kExrBand * 12.0,
                         fmt::format("decoding {} ({}x{} pixels)", name, hdr.width, hdr.height),
                         "the file is corrupt, or too large for this machine",
                         Error::Kind::kFormat);
  }
  try {
    MemoryIStream stream(bytes, name);
    Imf::InputFile file(stream, 0);
    const ExrLayout l = exr_layout(file.header(), name);
    const Tile t = rows.empty() ? Tile{0, 0, l.width, l.height} : rows;
    check_tile(t, l.width, l.height, name);

    // The tile's scanlines, full width, a band at a time; the tile's columns are kept. The
    // image grows with the bands read, so a header claiming more than the file holds fails
    // at the first missing band, not after allocating for all of them.
    const auto& dw = l.data_window;
    const std::size_t nc = l.grey ? 1 : 3;
    const std::array<const char*, 3> names = {"R", "G", "B"};
    std::vector<float> buf(std::size_t(l.width) * std::size_t(std::min(kExrBand, t.height)) * nc);
    Image img;
    img.width = t.width;
    img.height = t.height;
    img.format = SampleFormat::kHdr;
    for (int by = 0; by < t.height; by += kExrBand) {
      const int band_rows = std::min(kExrBand, t.height - by);
      const int y0 = dw.min.y + t.y + by, y1 = y0 + band_rows - 1;
      const Imath::Box2i band(Imath::V2i(dw.min.x, y0), Imath::V2i(dw.max.x, y1));
      Imf::FrameBuffer fb;
      for (std::size_t c = 0; c < nc; ++c)
        fb.insert(l.grey ? "Y" : names[c],
                  Imf::Slice::Make(Imf::FLOAT, buf.data() + c, band, nc * sizeof(float),
                                   std::size_t(l.width) * nc * sizeof(float)));
      file.setFrameBuffer(fb);
      file.readPixels(y0, y1);
      img.rgb.resize(std::size_t(t.width) * std::size_t(by + band_rows) * 3);
      for (int y = 0; y < band_rows; ++y)
        for (int x = 0; x < t.width; ++x) {
          const float* src =
              buf.data() + (std::size_t(y) * std::size_t(l.width) + std::size_t(t.x + x)) * nc;
          float* dst =
              img.rgb.data() + (std::size_t(by + y) * std::size_t(t.width) + std::size_t(x)) * 3;
          for (std::size_t c = 0; c < 3; ++c) {
            const float v = src[l.grey ? 0 : c];
            if (!std::isfinite(v))
              throw Error(Error::Kind::kFormat,
                          fmt::format("{} holds a non-finite value ({}) at pixel x={} y={}, "
                                      "channel {}; replace non-finite values before fitting",
                                      name, v, t.x + x, t.y + by + y, l.grey ? "Y" : names[c]));
            dst[c] = v;
          }
        }
    }
    return img;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    rethrow_exr(name, e.what());
  }
}

// ---- files -----------------------------------------------------------------------------

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

File open_for_reading(const fs::path& path) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot open {}: {}", path.string(), std::strerror(err)));
  }
  return f;
}

// Up to `max` bytes from `offset` (all of the rest when max is 0).
std::vector<std::uint8_t> read_bytes(std::FILE* f, const fs::path& path, std::uint64_t offset,
                                     std::size_t max) {
  if (std::fseek(f, 0, SEEK_END) != 0) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot read {}: {}", path.string(), std::strerror(err)));
  }
  const long end = std::ftell(f);
  if (end < 0) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot read {}: {}", path.string(), std::strerror(err)));
  }
  const std::uint64_t size = std::uint64_t(end);
  const std::uint64_t from = std::min(offset, size);
  std::uint64_t n = size - from;
  if (max != 0) n = std::min<std::uint64_t>(n, max);
  limits::check_memory(double(n), fmt::format("reading {} ({} bytes)", path.string(), n),
                       "it is not a BTF image; move it out of the folder", Error::Kind::kIo);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(n));
  if (std::fseek(f, static_cast<long>(from), SEEK_SET) != 0 ||
      std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size()) {
    const int err = std::ferror(f) ? errno : 0;
    throw Error(Error::Kind::kIo, fmt::format("cannot read {}: {}", path.string(),
                                              err ? std::strerror(err)
                                                  : "the file ended early (is it being "
                                                    "written?)"));
  }
  return bytes;
}

std::uint64_t file_size(std::FILE* f, const fs::path& path) {
  if (std::fseek(f, 0, SEEK_END) != 0) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot read {}: {}", path.string(), std::strerror(err)));
  }
  const long end = std::ftell(f);
  if (end < 0) {
    const int err = errno;
    throw Error(Error::Kind::kIo,
                fmt::format("cannot read {}: {}", path.string(), std::strerror(err)));
  }
  return std::uint64_t(end);
}

// Write `bytes` to `path` through a temporary file in the same folder and a rename.
void write_atomically(const fs::path& path, std::span<const std::uint8_t> bytes) {
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(parent, ec))
    throw Error(Error::Kind::kIo,
                fmt::format("cannot write {}: the folder {} does not exist; create it first",
                            path.string(), parent.string()));

  static std::atomic<std::uint64_t> counter{std::random_device{}()};
  const std::uint64_t id = counter.fetch_add(0x9e3779b97f4a7c15ull);
  const fs::path tmp = fs::path(path.string() + fmt::format(".tmp-{:08x}", id >> 32));

  auto fail = [&](const std::string& reason, int err = 0) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error(Error::Kind::kIo, fmt::format("cannot write {}: {}{}", path.string(), reason,
                                              err == ENOSPC || err == EDQUOT
                                                  ? "; free space on that disk or write elsewhere"
                                                  : ""));
  };

  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) fail(std::strerror(errno));
  const bool wrote = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const int write_err = errno;
  const bool closed = std::fclose(f) == 0;
  const int close_err = errno;
  if (!wrote) fail(std::strerror(write_err), write_err);
  if (!closed) fail(std::strerror(close_err), close_err);
  fs::rename(tmp, path, ec);
  if (ec) fail(ec.message());
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
  if (f == ImageFormat::kExr) return exr_decode(bytes, name, rows);
  return stb_decode(bytes, f, name, rows);
}

ImageHeader decode_image_header(std::span<const std::uint8_t> bytes, const std::string& name) {
  const ImageFormat f = detect_format(bytes, name);
  if (f == ImageFormat::kExr) return exr_header(bytes, name);
  return stb_header(bytes, f, name);
}

Image read_image(const fs::path& path, const Tile& rows) {
  File f = open_for_reading(path);
  const std::vector<std::uint8_t> bytes = read_bytes(f.get(), path, 0, 0);
  f.reset();
  return decode_image(bytes, path.string(), rows);
}

ImageHeader read_image_header(const fs::path& path) {
  File f = open_for_reading(path);
  const std::string name = path.string();
  const std::uint64_t size = file_size(f.get(), path);
  if (size > kHeaderPrefix) {
    // Headers only: the first 64 KiB, and for PNG and JPEG the file's last bytes, which must
    // end the image (IEND, EOI), so a truncated file is caught here. When that does not
    // settle it (a header further in, trailing bytes after the image), read the whole file.
    try {
      const auto prefix = read_bytes(f.get(), path, 0, kHeaderPrefix);
      const ImageHeader hdr = decode_image_header(prefix, name);
      const ImageFormat fmt = *image_format_from_bytes(prefix);
      if (fmt == ImageFormat::kExr) return hdr;
      const auto tail = read_bytes(f.get(), path, size - 12, 12);
      if (fmt == ImageFormat::kPng && std::memcmp(&tail[4], "IEND", 4) == 0) return hdr;
      if (fmt == ImageFormat::kJpeg && tail[10] == 0xff && tail[11] == 0xd9) return hdr;
    } catch (const Error& e) {
      if (e.kind() == Error::Kind::kIo) throw;
    }
  }
  const auto bytes = read_bytes(f.get(), path, 0, 0);
  const ImageHeader hdr = decode_image_header(bytes, name);
  const ImageFormat fmt = *image_format_from_bytes(bytes);
  if (fmt == ImageFormat::kPng) check_png_complete(bytes, name);
  if (fmt == ImageFormat::kJpeg) check_jpeg_complete(bytes, name);
  return hdr;
}

void write_png(const fs::path& path, int width, int height, std::span<const float> rgb) {
  check_write_args(path, width, height, rgb);
  std::vector<std::uint8_t> px(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    const float v = rgb[i];
    // NaN becomes 0; everything else is rounded and clamped to 0..255.
    px[i] = v >= 0.0f ? static_cast<std::uint8_t>(std::lround(std::min(v, 255.0f))) : 0;
  }
  std::vector<std::uint8_t> out;
  auto sink = [](void* ctx, void* data, int size) {
    auto* v = static_cast<std::vector<std::uint8_t>*>(ctx);
    const auto* p = static_cast<const std::uint8_t*>(data);
    v->insert(v->end(), p, p + size);
  };
  if (!stbi_write_png_to_func(sink, &out, width, height, 3, px.data(), width * 3))
    throw Error(Error::Kind::kIo,
                fmt::format("cannot write {}: PNG encoding failed", path.string()));
  write_atomically(path, out);
}

void write_exr(const fs::path& path, int width, int height, std::span<const float> rgb) {
  check_write_args(path, width, height, rgb);
  MemoryOStream stream(path.string());
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::FrameBuffer fb;
    // OpenEXR takes a char* but only reads from it when writing.
    char* base = reinterpret_cast<char*>(const_cast<float*>(rgb.data()));
    const std::size_t xs = 3 * sizeof(float), ys = std::size_t(width) * xs;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    Imf::OutputFile file(stream, header, 0);
    file.setFrameBuffer(fb);
    file.writePixels(height);
  } catch (const std::exception& e) {
    throw Error(Error::Kind::kIo,
                fmt::format("cannot write {}: OpenEXR: {}", path.string(), e.what()));
  }
  write_atomically(path, stream.bytes());
}

void write_image(const fs::path& path, const Image& image) {
  const auto f = image_format_from_name(path.filename().string());
  if (f == ImageFormat::kPng) return write_png(path, image.width, image.height, image.rgb);
  if (f == ImageFormat::kExr) return write_exr(path, image.width, image.height, image.rgb);
  throw Error(Error::Kind::kArgument,
              fmt::format("cannot write {}: images are written as .png (8-bit) or .exr "
                          "(float); JPEG and other formats are not written, change the "
                          "extension",
                          path.string()));
}

}  // namespace btfgmm
