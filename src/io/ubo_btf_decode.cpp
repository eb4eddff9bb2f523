// Decoding a Bonn .btf file's images over a tile (docs/FORMAT.md, "Decoding"): the spatial
// factors of the tile's pixels only, each channel's sum of U x (S x V), then, in the order of
// btflib's decode functions (btf.m: decode_texel, decode_abrdf), the colour model's inverse
// (undecorrelate.m), the dynamic-range transform (restore_dynamic_range.m) and the cosine factor
// divided out.
#include <Imath/half.h>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/ubo_btf.hpp"
#include "io/ubo_btf_source.hpp"

namespace btfgmm {
namespace detail {

void scalars_to_floats(const std::uint8_t* bytes, std::size_t count, int scalar_bytes, float* out) {
  for (std::size_t i = 0; i < count; ++i) {
    if (scalar_bytes == 2) {
      std::uint16_t bits = 0;
      std::memcpy(&bits, bytes + 2 * i, 2);
      Imath::half h;
      h.setBits(bits);
      out[i] = float(h);
    } else if (scalar_bytes == 4) {
      std::memcpy(out + i, bytes + 4 * i, 4);
    } else {
      double d = 0;
      std::memcpy(&d, bytes + 8 * i, 8);
      out[i] = std::abs(d) <= double(std::numeric_limits<float>::max()) ? float(d)
               : std::isnan(d) ? std::numeric_limits<float>::quiet_NaN()
                               : std::numeric_limits<float>::infinity();
    }
  }
}

}  // namespace detail

namespace {

// btflib's constant of the logarithmic forms: log(value + eps) is stored.
constexpr float kDynamicRangeEps = 1e-5f;

using Rgb = std::array<float, 3>;

// YUV to RGB, the matrix of btflib's undecorrelate.m (mat_YUV2RGB), applied as M * (Y, U, V).
Rgb yuv_to_rgb(const Rgb& yuv) {
  return {yuv[0] + 1.13983f * yuv[2], yuv[0] - 0.39465f * yuv[1] - 0.5806f * yuv[2],
          yuv[0] + 2.03211f * yuv[1]};
}

// The colour model's inverse: the stored (decorrelated) channels back to RGB, as btflib's
// undecorrelate.m does for each model number.
Rgb undecorrelate(const UboBtfHeader& h, Rgb v) {
  const float eps = kDynamicRangeEps;
  switch (h.colour_model) {
    case 0:  // RGB
      return v;
    case 1:  // YUV
      return yuv_to_rgb(v);
    case 3: {  // PCA: the row vector times the matrix (row-major in the file), plus the mean
      const auto& m = h.colour_matrix;
      Rgb out{};
      for (int j = 0; j < 3; ++j)
        out[j] = v[0] * m[0 * 3 + j] + v[1] * m[1 * 3 + j] + v[2] * m[2 * 3 + j] + h.colour_mean[j];
      return out;
    }
    case 4:  // YCoCg
      return {v[0] + v[1] - v[2], v[0] + v[2], v[0] - v[1] - v[2]};
    case 9:  // Ylog U V
      v[0] = std::exp(v[0]) - eps;
      return yuv_to_rgb(v);
    case 10:  // Ylog Ulog Vlog: U = sign(u) exp(|u| + log eps)
      v[0] = std::exp(v[0]) - eps;
      for (int c = 1; c < 3; ++c) v[c] = std::copysign(eps * std::exp(std::abs(v[c])), v[c]);
      return yuv_to_rgb(v);
    case 11:  // Ylog U/Y V/Y: U = u (Y + eps)
      v[0] = std::exp(v[0]) - eps;
      v[1] *= v[0] + eps;
      v[2] *= v[0] + eps;
      return yuv_to_rgb(v);
    default:  // 12, log RGB
      return {std::exp(v[0]) - eps, std::exp(v[1]) - eps, std::exp(v[2]) - eps};
  }
}

// The dynamic-range transform (FMF with a reduction method other than 0): exp(x) - eps.
Rgb restore_dynamic_range(const UboBtfHeader& h, Rgb v) {
  if (h.kind != UboKind::kFmf || h.dynamic_range_reduction == 0) return v;
  for (float& x : v) x = std::exp(x) - kDynamicRangeEps;
  return v;
}

// The light's cos(theta) divided out where the header says the data holds it.
Rgb remove_cosine(const UboBtfHeader& h, std::size_t light, Rgb v) {
  if (!h.cosine_in_data) return v;
  const double cos_theta = std::cos(h.lights[light].theta_deg * std::numbers::pi / 180.0);
  for (float& x : v) x = float(x / cos_theta);
  return v;
}

Tile checked_tile(const UboBtfHeader& h, const std::string& name, const Tile& tile) {
  const Tile t = tile.or_whole(h.width, h.height);
  if (t.x < 0 || t.y < 0 || std::int64_t(t.x) + t.width > h.width ||
      std::int64_t(t.y) + t.height > h.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile x={} y={} {}x{} is not inside the images of {} ({}x{}); give a "
                            "tile inside them",
                            t.x, t.y, t.width, t.height, name, h.width, h.height));
  return t;
}

}  // namespace

double UboBtf::tile_bytes(const Tile& tile) const {
  const Tile t = tile.or_whole(header_.width, header_.height);
  double bytes = 0;
  for (const Matrix& m : matrices_) bytes += double(m.components) * t.width * t.height * 4.0;
  return bytes;
}

UboTileFactors UboBtf::load_tile(const Tile& tile) const {
  UboTileFactors f;
  f.tile = checked_tile(header_, name_, tile);
  const Tile& t = f.tile;
  const std::size_t pixels = std::size_t(t.width) * std::size_t(t.height);
  const int ss = header_.scalar_bytes;
  for (const Matrix& m : matrices_) {
    const std::size_t k_n = m.components;
    std::vector<float> sxv(k_n * pixels);
    std::vector<std::uint8_t> raw(std::size_t(t.width) * k_n * std::size_t(ss));
    std::vector<float> row(std::size_t(t.width) * k_n);
    for (int y = 0; y < t.height; ++y) {
      const std::uint64_t first = std::uint64_t(t.y + y) * header_.width + std::uint64_t(t.x);
      source_->read(m.sxv_offset + first * k_n * std::uint64_t(ss), raw.size(), raw.data());
      detail::scalars_to_floats(raw.data(), row.size(), ss, row.data());
      for (std::size_t i = 0; i < row.size(); ++i) {
        const std::size_t x = i / k_n, k = i % k_n;
        if (!std::isfinite(row[i]))
          throw Error(Error::Kind::kFormat,
                      fmt::format("{}: S x V holds {} at pixel x={} y={}, component {}; the file "
                                  "is damaged",
                                  name_, std::isnan(row[i]) ? "NaN" : "an infinity", t.x + int(x),
                                  t.y + y, k));
        sxv[k * pixels + std::size_t(y) * std::size_t(t.width) + x] = row[i];
      }
    }
    f.sxv.push_back(std::move(sxv));
  }
  return f;
}

void UboBtf::decode(const UboTileFactors& f, std::size_t light, std::size_t view,
                    std::span<float> rgb) const {
  const std::size_t pixels = std::size_t(f.tile.width) * std::size_t(f.tile.height);
  const std::size_t pair = view * header_.lights.size() + light;  // the file's rows: view-major
  std::vector<float> sums(pixels * 3, 0.0f);
  for (std::size_t c = 0; c < 3; ++c) {
    const bool dfmf = header_.kind == UboKind::kDfmf;
    const Matrix& m = matrices_[dfmf ? c : 0];
    const float* u = m.u.data() + (dfmf ? pair : pair * 3 + c) * m.components;
    const std::vector<float>& sxv = f.sxv[dfmf ? c : 0];
    float* out = sums.data() + c * pixels;
    for (std::size_t k = 0; k < m.components; ++k) {
      const float uk = u[k];
      const float* col = sxv.data() + k * pixels;
#pragma omp simd
      for (std::size_t p = 0; p < pixels; ++p) out[p] += uk * col[p];
    }
  }
  for (std::size_t p = 0; p < pixels; ++p) {
    Rgb v{sums[p], sums[pixels + p], sums[2 * pixels + p]};
    if (header_.kind == UboKind::kDfmf) v = undecorrelate(header_, v);
    v = remove_cosine(header_, light, restore_dynamic_range(header_, v));
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      throw Error(Error::Kind::kFormat,
                  fmt::format("{}: light {}, view {} decodes to a value that is not finite at "
                              "pixel x={} y={}; the factors are damaged",
                              name_, light, view, f.tile.x + int(p % std::size_t(f.tile.width)),
                              f.tile.y + int(p / std::size_t(f.tile.width))));
    for (int c = 0; c < 3; ++c) rgb[p * 3 + std::size_t(c)] = v[std::size_t(c)];
  }
}

}  // namespace btfgmm
