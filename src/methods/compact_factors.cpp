// Compact factors (docs/FORMAT.md, "Compact factors"): power-of-two steps per row, codes less
// their planar prediction on the row's grid, colour planes G, R - G, B - G, zstd.
#include "methods/compact_factors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "btfgmm/core/error.hpp"
#include "model/coded_columns.hpp"

namespace btfgmm::detail {
namespace {

// Codes no larger than this are whole numbers a double holds exactly.
constexpr double kLargestCode = 9007199254740992.0;  // 2^53
// The steps a file may state: 2^e for e in this range (a float's bits lie in 2^-149..2^127).
constexpr int kLowestExponent = -160, kHighestExponent = 160;
// A block of more values than this must bring a compressed byte for every
// kValuesPerCompressedByte of them: the bound that keeps a small corrupted file from claiming
// gigabytes (zstd itself expands up to 32768-fold).
constexpr double kFreeValues = 16777216.0, kValuesPerCompressedByte = 1024.0;

// The exponent e of the largest power of two that divides v (v != 0, finite).
int trailing_exponent(float v) {
  int e = 0;
  const double m = std::frexp(double(v), &e);  // |v| = |m| 2^e, |m| in [0.5, 1)
  const auto bits = std::uint32_t(std::ldexp(std::abs(m), 24));
  return e - 24 + std::countr_zero(bits);
}

// The exponent of the step put_compact_factors states for a row: the largest power of two of
// which every value is a whole multiple (0 for a row of zeros).
int row_exponent(std::span<const float> row) {
  int e = kHighestExponent;
  for (float v : row)
    if (v != 0.0f) e = std::min(e, trailing_exponent(v));
  return e == kHighestExponent ? 0 : e;
}

// How a row's codes split into planes: `channels` interleaved, each a grid `across` wide.
struct Planes {
  std::size_t channels = 1, size = 0, across = 1;
};

Planes planes_of(std::size_t cols, FactorLayout layout) {
  Planes p;
  p.channels = layout.channels > 0 && cols % layout.channels == 0 ? layout.channels : 1;
  p.size = cols / p.channels;
  p.across = layout.across > 0 && layout.across < p.size ? layout.across
                                                         : std::max<std::size_t>(p.size, 1);
  return p;
}

// A row's codes (interleaved channels) as planes, one after another: with three channels G,
// R - G and B - G (the colour differences vary less than the colours).
std::vector<std::int64_t> colour_planes(std::span<const std::int64_t> q, const Planes& p) {
  std::vector<std::int64_t> out(q.size());
  for (std::size_t i = 0; i < p.size; ++i)
    for (std::size_t c = 0; c < p.channels; ++c) out[c * p.size + i] = q[i * p.channels + c];
  if (p.channels == 3)
    for (std::size_t i = 0; i < p.size; ++i) {
      std::swap(out[i], out[p.size + i]);  // G first
      out[p.size + i] = wrapping_minus(out[p.size + i], out[i]);
      out[2 * p.size + i] = wrapping_minus(out[2 * p.size + i], out[i]);
    }
  return out;
}

std::vector<std::int64_t> interleaved(std::vector<std::int64_t> planes, const Planes& p) {
  if (p.channels == 3)
    for (std::size_t i = 0; i < p.size; ++i) {
      planes[p.size + i] = wrapping_plus(planes[p.size + i], planes[i]);
      planes[2 * p.size + i] = wrapping_plus(planes[2 * p.size + i], planes[i]);
      std::swap(planes[i], planes[p.size + i]);
    }
  std::vector<std::int64_t> q(planes.size());
  for (std::size_t i = 0; i < p.size; ++i)
    for (std::size_t c = 0; c < p.channels; ++c) q[i * p.channels + c] = planes[c * p.size + i];
  return q;
}

// Each code of each plane less its planar prediction from the codes before it.
void predict_row(std::span<std::int64_t> planes, const Planes& p) {
  for (std::size_t c = 0; c < p.channels; ++c) {
    const std::span<std::int64_t> plane = planes.subspan(c * p.size, p.size);
    for (std::size_t i = p.size; i-- > 0;)
      plane[i] = wrapping_minus(plane[i], planar_prediction(plane, i, p.across));
  }
}

void unpredict_row(std::span<std::int64_t> planes, const Planes& p) {
  for (std::size_t c = 0; c < p.channels; ++c) {
    const std::span<std::int64_t> plane = planes.subspan(c * p.size, p.size);
    for (std::size_t i = 0; i < p.size; ++i)
      plane[i] = wrapping_plus(plane[i], planar_prediction(plane, i, p.across));
  }
}

// A row's codes at step 2^e; Error(kArgument) where a value is no whole multiple of it.
std::vector<std::int64_t> row_codes(std::span<const float> row, int e) {
  std::vector<std::int64_t> q(row.size());
  for (std::size_t j = 0; j < row.size(); ++j) {
    const double c = std::ldexp(double(row[j]), -e);
    if (!(std::abs(c) < kLargestCode) || c != std::round(c))
      throw Error(Error::Kind::kArgument,
                  "a factor to store compactly was not quantised to a step (quantise_factors)");
    q[j] = std::int64_t(c);
  }
  return q;
}

}  // namespace

double compact_step_of_range() {
  return 2.0 / 255.0;
}

double compact_step(double lo, double hi) {
  const double span = hi > lo ? hi - lo : std::abs(hi);
  if (!(span > 0.0) || !std::isfinite(span)) return 0.0;
  const int e = int(std::floor(std::log2(compact_step_of_range() * span)));
  return std::ldexp(1.0, std::clamp(e, -149, 127));
}

void quantise_compact(std::span<float> values, std::size_t cols) {
  for (std::size_t r = 0; r * cols < values.size(); ++r) {
    const std::span<float> row = values.subspan(r * cols, cols);
    const auto [lo, hi] = std::minmax_element(row.begin(), row.end());
    const double step = compact_step(*lo, *hi);
    if (step == 0.0) continue;
    // + 0.0f: no negative zero, which would be stored as zero.
    for (float& v : row) v = float(std::round(double(v) / step) * step) + 0.0f;
  }
}

void put_compact_factors(ByteWriter& w, std::span<const float> values, std::size_t cols,
                         FactorLayout layout) {
  const std::size_t rows = cols ? values.size() / cols : 0;
  const Planes p = planes_of(cols, layout);
  CodeColumn exponents(rows), residuals;
  residuals.reserve(values.size());
  for (std::size_t r = 0; r < rows; ++r) {
    const std::span<const float> row = values.subspan(r * cols, cols);
    exponents[r] = row_exponent(row);
    std::vector<std::int64_t> planes = colour_planes(row_codes(row, int(exponents[r])), p);
    predict_row(planes, p);
    residuals.insert(residuals.end(), planes.begin(), planes.end());
  }
  std::vector<std::uint8_t> raw;
  put_column(raw, exponents);
  put_column(raw, residuals);
  const std::vector<std::uint8_t> packed = zstd_pack(raw);
  w.put<std::uint64_t>(std::uint64_t(raw.size()));
  w.put<std::uint32_t>(std::uint32_t(packed.size()));
  w.bytes.insert(w.bytes.end(), packed.begin(), packed.end());
}

std::vector<float> get_compact_factors(ByteReader& r, std::size_t rows, std::size_t cols,
                                       FactorLayout layout, const char* field) {
  const auto raw_size = r.get<std::uint64_t>(field);
  const auto packed_size = r.get<std::uint32_t>(field);
  if (packed_size > r.remaining())
    r.fail(fmt::format("{}: {} compressed bytes, {} left in the file", field, packed_size,
                       r.remaining()));
  const double count = double(rows) * double(cols);
  // Each code takes 1..8 bytes, each column a width byte.
  if (double(raw_size) < 2.0 + double(rows) + count ||
      double(raw_size) > 2.0 + 8.0 * (double(rows) + count))
    r.fail(
        fmt::format("{}: {} coded bytes cannot hold {} x {} values", field, raw_size, rows, cols));
  if (count > kFreeValues && count > kValuesPerCompressedByte * double(packed_size))
    r.fail(
        fmt::format("{}: {} x {} values in {} compressed bytes is more than the encoding "
                    "packs",
                    field, rows, cols, packed_size));
  std::vector<std::uint8_t> packed(packed_size);
  for (auto& b : packed) b = r.get<std::uint8_t>(field);
  const std::vector<std::uint8_t> raw = zstd_unpack(r, packed, raw_size);
  ByteReader cr(raw, "model file", fmt::format("(the compressed {})", field),
                "fit the model again");
  const CodeColumn exponents = get_column(cr, rows);
  CodeColumn residuals = get_column(cr, rows * cols);
  if (cr.remaining() != 0)
    r.fail(fmt::format("{}: the compressed codes hold bytes left over", field));
  const Planes p = planes_of(cols, layout);
  std::vector<float> out(rows * cols);
  for (std::size_t row = 0; row < rows; ++row) {
    const std::int64_t e = exponents[row];
    if (e < kLowestExponent || e > kHighestExponent)
      r.fail(fmt::format("{}: row {} states a step of 2^{}", field, row, e));
    const std::span<std::int64_t> planes = std::span(residuals).subspan(row * cols, cols);
    unpredict_row(planes, p);
    const std::vector<std::int64_t> q = interleaved({planes.begin(), planes.end()}, p);
    for (std::size_t j = 0; j < cols; ++j) {
      const double v = std::ldexp(double(q[j]), int(e));
      if (!(std::abs(double(q[j])) < kLargestCode) || !std::isfinite(float(v)) ||
          double(float(v)) != v)
        r.fail(fmt::format("{}: value {} of row {} does not fit a 32-bit float", field, j, row));
      out[row * cols + j] = float(v);
    }
  }
  return out;
}

}  // namespace btfgmm::detail
