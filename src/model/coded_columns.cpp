// Zigzagged codes in byte planes, compressed with zstd: the storage of the compact encodings.
#include "model/coded_columns.hpp"

#include <fmt/format.h>
#include <zstd.h>

#include "btfgmm/core/error.hpp"

namespace btfgmm::detail {
namespace {

constexpr int kZstdLevel = 19;
// The most a zstd frame can expand: 128 KiB from each block of at least 4 bytes (RFC 8878).
constexpr double kZstdMaxRatio = 131072.0 / 4.0;

}  // namespace

std::uint64_t zigzag(std::int64_t v) {
  return (std::uint64_t(v) << 1) ^ std::uint64_t(v >> 63);
}

std::int64_t unzigzag(std::uint64_t z) {
  return std::int64_t(z >> 1) ^ -std::int64_t(z & 1);
}

std::int64_t wrapping_plus(std::int64_t a, std::int64_t b) {
  return std::int64_t(std::uint64_t(a) + std::uint64_t(b));
}

std::int64_t wrapping_minus(std::int64_t a, std::int64_t b) {
  return std::int64_t(std::uint64_t(a) - std::uint64_t(b));
}

std::int64_t planar_prediction(std::span<const std::int64_t> p, std::size_t i, std::size_t across) {
  const bool left = i % across != 0, up = i >= across;
  const std::int64_t a = left ? p[i - 1] : up ? p[i - across] : 0;
  const std::int64_t b = up ? p[i - across] : a;
  const std::int64_t c = left && up ? p[i - across - 1] : a;
  return wrapping_minus(wrapping_plus(a, b), c);
}

void put_column(std::vector<std::uint8_t>& out, std::span<const std::int64_t> c) {
  std::uint64_t top = 0;
  for (std::int64_t v : c) top |= zigzag(v);
  std::uint8_t k = 1;
  while (k < 8 && (top >> (8 * k)) != 0) ++k;
  out.push_back(k);
  for (int plane = 0; plane < k; ++plane)
    for (std::int64_t v : c) out.push_back(std::uint8_t(zigzag(v) >> (8 * plane)));
}

CodeColumn get_column(ByteReader& r, std::size_t n) {
  const auto k = r.get<std::uint8_t>("column width");
  if (k < 1 || k > 8) r.fail(fmt::format("a compact column of {} bytes a code", int(k)));
  if (double(k) * double(n) > double(r.remaining())) r.fail("a compact column runs past its block");
  std::vector<std::uint64_t> z(n, 0);
  for (int plane = 0; plane < k; ++plane)
    for (std::size_t i = 0; i < n; ++i)
      z[i] |= std::uint64_t(r.get<std::uint8_t>("code")) << (8 * plane);
  CodeColumn c(n);
  for (std::size_t i = 0; i < n; ++i) c[i] = unzigzag(z[i]);
  return c;
}

std::vector<std::uint8_t> zstd_pack(std::span<const std::uint8_t> raw) {
  std::vector<std::uint8_t> packed(ZSTD_compressBound(raw.size()));
  const std::size_t n =
      ZSTD_compress(packed.data(), packed.size(), raw.data(), raw.size(), kZstdLevel);
  if (ZSTD_isError(n))
    throw Error(Error::Kind::kIo,
                fmt::format("zstd could not compress the model: {}", ZSTD_getErrorName(n)));
  packed.resize(n);
  return packed;
}

std::vector<std::uint8_t> zstd_unpack(const ByteReader& r, std::span<const std::uint8_t> packed,
                                      std::uint64_t raw_size) {
  if (ZSTD_getFrameContentSize(packed.data(), packed.size()) != raw_size)
    r.fail("the compressed codes do not hold the size the file states");
  // Before allocating for it: what the codes can hold at most.
  if (double(raw_size) > kZstdMaxRatio * double(packed.size()))
    r.fail(fmt::format("the compressed codes claim {} bytes, more than their {} bytes can hold",
                       raw_size, packed.size()));
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(raw_size));
  const std::size_t got = ZSTD_decompress(raw.data(), raw.size(), packed.data(), packed.size());
  if (ZSTD_isError(got) || got != raw.size()) r.fail("the compressed codes are corrupted");
  return raw;
}

}  // namespace btfgmm::detail
