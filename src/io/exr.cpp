// OpenEXR through OpenEXR 3, in memory: the header checked before anything is allocated for
// it, the pixels decoded a band of scanlines at a time (R, G, B or grey Y, as float), and
// float RGB encoding.
#include <fmt/format.h>

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
#include <cmath>
#include <cstring>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "io/codecs.hpp"

namespace btfgmm::detail {
namespace {

// OpenEXR images are decoded this many scanlines at a time.
constexpr int kExrBand = 64;

// ---- OpenEXR ---------------------------------------------------------------------------

// The file's bytes as OpenEXR's input stream. Positions come from the file (its offset
// tables), so any may be past the end or near 2^64: every check is written so that it cannot
// wrap around (n > size - pos, never pos + n > size).
class MemoryIStream final : public Imf::IStream {
 public:
  MemoryIStream(std::span<const std::uint8_t> bytes, const std::string& name)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}

  bool read(char c[], int n) override {
    if (n < 0 || std::uint64_t(n) > bytes_.size() - pos_)
      throw Iex::InputExc(fmt::format("the file ends at byte {}, inside {} bytes from byte {}",
                                      bytes_.size(), n, pos_));
    std::memcpy(c, bytes_.data() + pos_, std::size_t(n));
    pos_ += std::uint64_t(n);
    return pos_ < bytes_.size();
  }
  std::uint64_t tellg() override { return pos_; }
  // pos_ stays within the file: an offset past its end is refused where it is followed.
  void seekg(std::uint64_t pos) override {
    if (pos > bytes_.size())
      throw Iex::InputExc(fmt::format("an offset in the file ({}) points past its end ({} bytes)",
                                      pos, bytes_.size()));
    pos_ = pos;
  }
  void clear() override {}

 private:
  std::span<const std::uint8_t> bytes_;
  std::uint64_t pos_ = 0;  // <= bytes_.size()
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

}  // namespace

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
    const Tile t = rows.or_whole(hdr.width, hdr.height);
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
    const Tile t = rows.or_whole(l.width, l.height);
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

std::vector<std::uint8_t> encode_exr(int width, int height, std::span<const float> rgb,
                                     const std::string& name) {
  MemoryOStream stream(name);
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
    throw Error(Error::Kind::kIo, fmt::format("cannot write {}: OpenEXR: {}", name, e.what()));
  }
  return std::move(stream.bytes());
}

}  // namespace btfgmm::detail
