// Factors stored as f32, f16 or 8-bit codes with a per-row offset and scale; the frame.
#include "methods/factors.hpp"

#include <fmt/format.h>

#include <Imath/half.h>
#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "methods/compact_factors.hpp"

namespace btfgmm {

std::string_view to_string(FactorEncoding e) {
  switch (e) {
    case FactorEncoding::kF32:
      return "f32";
    case FactorEncoding::kF16:
      return "f16";
    case FactorEncoding::kQ8:
      return "q8";
    case FactorEncoding::kCompact:
      return "compact";
  }
  return "?";
}

FactorEncoding parse_factor_encoding(std::string_view text, std::string_view option) {
  if (text == "f32") return FactorEncoding::kF32;
  if (text == "f16") return FactorEncoding::kF16;
  if (text == "q8") return FactorEncoding::kQ8;
  if (text == "compact") return FactorEncoding::kCompact;
  throw Error(Error::Kind::kArgument,
              fmt::format("{} '{}': give compact (quantised with a step per component, predicted "
                          "from neighbours, zstd), f32 (32-bit floats), f16 (16-bit floats) or q8 "
                          "(8 bits with an offset and scale per component)",
                          option, text));
}

namespace detail {
namespace {

// A row's offset and scale for 8-bit codes: value = offset + scale * code, code 0..255.
struct RowScale {
  float offset = 0.0f, scale = 0.0f;
};

RowScale row_scale(std::span<const float> row) {
  const auto [lo, hi] = std::minmax_element(row.begin(), row.end());
  RowScale s;
  s.offset = *lo;
  s.scale = float((double(*hi) - double(*lo)) / 255.0);
  return s;
}

std::uint8_t code_of(float v, RowScale s) {
  if (s.scale == 0.0f) return 0;
  const double c = std::round((double(v) - double(s.offset)) / double(s.scale));
  return std::uint8_t(std::clamp(c, 0.0, 255.0));
}

float value_of(std::uint8_t code, RowScale s) {
  return float(double(s.offset) + double(s.scale) * double(code));
}

float half_of(float v) {
  return float(Imath::half(v));
}

}  // namespace

FactorLayout image_layout(const ModelFrame& f) {
  return {std::size_t(f.width), 3};
}

FactorLayout directions_layout(const ModelFrame& f, std::size_t channels) {
  return {f.views.size(), channels};
}

double factor_error_bound(FactorEncoding e, double lo, double hi) {
  switch (e) {
    case FactorEncoding::kF32:
      return 0.0;
    case FactorEncoding::kF16:
      return std::max(std::abs(lo), std::abs(hi)) * std::ldexp(1.0, -11);
    case FactorEncoding::kQ8:
      return (hi - lo) / 255.0 * 0.5 * (1.0 + 1e-6);
    case FactorEncoding::kCompact:
      return compact_step(lo, hi) * 0.5 * (1.0 + 1e-6);
  }
  return 0.0;
}

void quantise_factors(std::span<float> values, std::size_t cols, FactorEncoding e) {
  for (float v : values)
    if (!std::isfinite(v))
      throw Error(Error::Kind::kArgument, "a factor to store is not finite (NaN or infinite)");
  if (e == FactorEncoding::kF32 || cols == 0) return;
  if (e == FactorEncoding::kCompact) return quantise_compact(values, cols);
  if (e == FactorEncoding::kF16) {
    for (float& v : values) {
      if (!(std::abs(v) <= kHalfMax))
        throw Error(Error::Kind::kArgument,
                    fmt::format("a factor to store as f16 is {:.6g}, beyond a 16-bit float's "
                                "range (magnitudes up to {:g}), and its file would not read "
                                "back; store it as compact (the default), q8 or f32",
                                v, kHalfMax));
      v = half_of(v);
    }
    return;
  }
  // Repeated until the row's offset and scale are those of its own quantised values, so that
  // put_factors (which derives them again) writes codes that read back to these very floats.
  for (std::size_t r = 0; r * cols < values.size(); ++r) {
    std::span<float> row = values.subspan(r * cols, cols);
    for (int pass = 0; pass < 8; ++pass) {
      const RowScale s = row_scale(row);
      for (float& v : row) v = value_of(code_of(v, s), s);
      const RowScale t = row_scale(row);
      if (t.offset == s.offset && t.scale == s.scale) break;
    }
  }
}

std::size_t factor_bytes(std::size_t rows, std::size_t cols, FactorEncoding e) {
  const std::size_t header = 1 + 4 + 4;
  switch (e) {
    case FactorEncoding::kF32:
      return header + rows * cols * 4;
    case FactorEncoding::kF16:
      return header + rows * cols * 2;
    case FactorEncoding::kQ8:
      return header + rows * (8 + cols);
    case FactorEncoding::kCompact:
      break;
  }
  throw Error(Error::Kind::kArgument,
              "the compact encoding's size is known once its factors are coded");
}

void put_factors(ByteWriter& w, std::span<const float> values, std::size_t cols, FactorEncoding e,
                 FactorLayout layout) {
  const std::size_t rows = cols ? values.size() / cols : 0;
  w.put<std::uint8_t>(std::uint8_t(e));
  w.put<std::uint32_t>(std::uint32_t(rows));
  w.put<std::uint32_t>(std::uint32_t(cols));
  if (e == FactorEncoding::kCompact) {
    put_compact_factors(w, values, cols, layout);
  } else if (e == FactorEncoding::kF32) {
    for (float v : values) w.put<float>(v);
  } else if (e == FactorEncoding::kF16) {
    for (float v : values) w.put<std::uint16_t>(Imath::half(v).bits());
  } else {
    for (std::size_t r = 0; r < rows; ++r) {
      std::span<const float> row = values.subspan(r * cols, cols);
      const RowScale s = row_scale(row);
      w.put<float>(s.offset);
      w.put<float>(s.scale);
      for (float v : row) w.put<std::uint8_t>(code_of(v, s));
    }
  }
}

std::vector<float> get_factors(ByteReader& r, std::size_t rows, std::size_t cols, const char* field,
                               FactorLayout layout) {
  const auto e = r.get<std::uint8_t>(field);
  if (e > 3) r.fail(fmt::format("{}: unknown factor encoding {}", field, e));
  const auto got_rows = r.get<std::uint32_t>(field), got_cols = r.get<std::uint32_t>(field);
  if (got_rows != rows || got_cols != cols)
    r.fail(fmt::format("{}: {} x {} values where the model needs {} x {}", field, got_rows,
                       got_cols, rows, cols));
  const auto enc = FactorEncoding(e);
  if (enc == FactorEncoding::kCompact) return get_compact_factors(r, rows, cols, layout, field);
  // In doubles: rows and cols come from the file, and their product may not fit 64 bits.
  const double row_bytes = enc == FactorEncoding::kQ8    ? 8.0 + double(cols)
                           : enc == FactorEncoding::kF16 ? 2.0 * double(cols)
                                                         : 4.0 * double(cols);
  if (double(rows) * row_bytes > double(r.remaining()))
    r.fail(fmt::format("{}: {} x {} values do not fit the file", field, rows, cols));
  std::vector<float> v(rows * cols);
  if (enc == FactorEncoding::kF32) {
    for (float& x : v) x = r.get<float>(field);
  } else if (enc == FactorEncoding::kF16) {
    for (float& x : v) {
      Imath::half h;
      h.setBits(r.get<std::uint16_t>(field));
      x = float(h);
    }
  } else {
    for (std::size_t row = 0; row < rows; ++row) {
      RowScale s;
      s.offset = r.get<float>(field);
      s.scale = r.get<float>(field);
      if (!std::isfinite(s.offset) || !(s.scale >= 0.0f) || !std::isfinite(s.scale))
        r.fail(fmt::format("{}: row {} has a bad offset or scale", field, row));
      for (std::size_t c = 0; c < cols; ++c)
        v[row * cols + c] = value_of(r.get<std::uint8_t>(field), s);
    }
  }
  for (float x : v)
    if (!std::isfinite(x)) r.fail(fmt::format("{} holds a non-finite value", field));
  return v;
}

void put_frame(ByteWriter& w, const ModelFrame& f) {
  put_tile(w, f.width, f.height, f.origin, f.format);
  put_directions(w, f.lights);
  put_directions(w, f.views);
}

ModelFrame get_frame(ByteReader& r) {
  ModelFrame f;
  get_tile(r, f.width, f.height, f.origin, f.format);
  f.lights = get_directions(r, "light directions");
  f.views = get_directions(r, "view directions");
  return f;
}

std::size_t get_count(ByteReader& r, std::size_t lo, std::size_t hi, const char* field) {
  const auto n = r.get<std::uint32_t>(field);
  if (n < lo || n > hi) r.fail(fmt::format("{} {} is outside [{}, {}]", field, n, lo, hi));
  return n;
}

}  // namespace detail
}  // namespace btfgmm
