// 8-bit RGB PNG encoding through zlib (codecs.hpp): the rows filtered by "up" (each byte less
// the byte above it; the first row unfiltered), deflated with run-length matches only (zlib's
// Z_RLE), in bands of rows compressed side by side by the threads. Run-length matches reach
// one byte back, so the bands lose almost nothing by being compressed apart (a run cut at a
// band's end, a few bytes of flush and code tables a band);
// they are joined into one zlib stream as pigz joins its blocks (each band but the last ends
// on a byte boundary by a sync flush; the Adler-32 sums combined).
//
// Rendered pictures (a background of one colour, smooth shading) come out about a third
// smaller than stb_image_write's default and several times faster (docs/BENCHMARKS.md).
#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

#include "btfgmm/core/error.hpp"
#include "io/codecs.hpp"

namespace btfgmm::detail {

std::vector<std::uint8_t> to_levels(std::span<const float> rgb) {
  std::vector<std::uint8_t> px(rgb.size());
  const float* in = rgb.data();
  std::uint8_t* out = px.data();
  const std::ptrdiff_t n = std::ptrdiff_t(rgb.size());
  // NaN and negatives become 0; v + 0.5 in double is exact for a float v in [0, 255], and
  // truncated it is lround's rounding (halves away from zero).
#pragma omp simd
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    float v = in[i] > 0.0f ? in[i] : 0.0f;
    v = v < 255.0f ? v : 255.0f;
    out[i] = static_cast<std::uint8_t>(static_cast<int>(double(v) + 0.5));
  }
  return px;
}

namespace {

// A band of rows deflated: its piece of the raw deflate stream (empty where zlib failed), the
// Adler-32 sum and the length of its filtered bytes.
struct Band {
  std::vector<std::uint8_t> bytes;
  uLong adler = 0;
  uLong length = 0;
};

// Rows rows[0] to rows[1] (excluded) of the picture's levels, each a filter byte and its
// filtered bytes, deflated; `last` ends the stream.
Band deflate_band(const std::vector<std::uint8_t>& px, std::size_t row_bytes,
                  std::array<std::size_t, 2> rows, bool last) {
  Band b;
  std::vector<std::uint8_t> filtered((rows[1] - rows[0]) * (row_bytes + 1));
  for (std::size_t y = rows[0]; y < rows[1]; ++y) {
    std::uint8_t* out = filtered.data() + (y - rows[0]) * (row_bytes + 1);
    const std::uint8_t* cur = px.data() + y * row_bytes;
    out[0] = y == 0 ? 0 : 2;  // none, up
    if (y == 0) {
      std::memcpy(out + 1, cur, row_bytes);
    } else {
      for (std::size_t i = 0; i < row_bytes; ++i)
        out[1 + i] = std::uint8_t(cur[i] - cur[i - row_bytes]);
    }
  }
  b.length = uLong(filtered.size());
  b.adler = adler32(adler32(0L, Z_NULL, 0), filtered.data(), uInt(filtered.size()));
  z_stream zs{};
  if (deflateInit2(&zs, 1, Z_DEFLATED, -15, 8, Z_RLE) != Z_OK) return b;
  std::vector<std::uint8_t> out(deflateBound(&zs, uLong(filtered.size())) + 64);
  zs.next_in = filtered.data();
  zs.avail_in = uInt(filtered.size());
  zs.next_out = out.data();
  zs.avail_out = uInt(out.size());
  const int r = deflate(&zs, last ? Z_FINISH : Z_SYNC_FLUSH);
  const bool ok = last ? r == Z_STREAM_END : r == Z_OK && zs.avail_in == 0 && zs.avail_out > 0;
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (ok) b.bytes = std::move(out);
  return b;
}

void put32(std::vector<std::uint8_t>& v, std::uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) v.push_back(std::uint8_t(x >> s));
}

// A chunk: its length, type, data and CRC of type and data.
void put_chunk(std::vector<std::uint8_t>& v, const char* type, std::span<const std::uint8_t> data) {
  put32(v, std::uint32_t(data.size()));
  const std::size_t start = v.size();
  v.insert(v.end(), type, type + 4);
  v.insert(v.end(), data.begin(), data.end());
  put32(v, std::uint32_t(crc32(crc32(0L, Z_NULL, 0), v.data() + start, uInt(v.size() - start))));
}

}  // namespace

std::vector<std::uint8_t> encode_png(int width, int height, std::span<const float> rgb,
                                     const std::string& name) {
  const std::vector<std::uint8_t> px = to_levels(rgb);
  const std::size_t row_bytes = std::size_t(width) * 3, h = std::size_t(height);
  // Bands of at least 100 rows, at most 8: as many whatever the threads, so that the file's
  // bytes do not depend on the machine.
  const std::size_t bands = std::clamp<std::size_t>(h / 100, 1, 8);
  std::vector<Band> band(bands);
#pragma omp parallel for schedule(dynamic, 1) if (bands > 1)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(bands); ++k) {
    const std::size_t b = std::size_t(k);
    band[b] = deflate_band(px, row_bytes, {h * b / bands, h * (b + 1) / bands}, b + 1 == bands);
  }
  // The zlib stream: its header (deflate, 32 KiB window, no dictionary), the bands, Adler-32.
  std::vector<std::uint8_t> zlib = {0x78, 0x01};
  uLong adler = band[0].adler;
  for (std::size_t b = 0; b < bands; ++b) {
    if (band[b].bytes.empty())
      throw Error(Error::Kind::kIo, fmt::format("cannot write {}: PNG compression failed", name));
    zlib.insert(zlib.end(), band[b].bytes.begin(), band[b].bytes.end());
    if (b > 0) adler = adler32_combine(adler, band[b].adler, z_off_t(band[b].length));
  }
  put32(zlib, std::uint32_t(adler));

  std::vector<std::uint8_t> out(kPngMagic.begin(), kPngMagic.end());
  std::vector<std::uint8_t> ihdr;
  put32(ihdr, std::uint32_t(width));
  put32(ihdr, std::uint32_t(height));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bits, RGB, deflate, adaptive filters, no interlace
  put_chunk(out, "IHDR", ihdr);
  put_chunk(out, "IDAT", zlib);
  put_chunk(out, "IEND", {});
  return out;
}

}  // namespace btfgmm::detail
