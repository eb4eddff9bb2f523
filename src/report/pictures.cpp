// The report's pictures; see pictures.hpp and docs/METRICS.md.
#include "btfgmm/report/pictures.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

namespace {

double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

}  // namespace

Image display_image(std::span<const float> rgb, int width, int height, SampleFormat format,
                    double range) {
  Image out;
  out.width = width;
  out.height = height;
  out.rgb.resize(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i)
    out.rgb[i] = format == SampleFormat::kHdr ? float(255.0 * srgb_encode(double(rgb[i]) / range))
                                              : std::clamp(rgb[i], 0.0f, 255.0f);
  return out;
}

Image difference_image(std::span<const float> original, std::span<const float> model, int width,
                       int height, SampleFormat format, double range, double scale) {
  if (original.size() != model.size() ||
      original.size() != std::size_t(width) * std::size_t(height) * 3)
    throw Error(Error::Kind::kArgument,
                fmt::format("difference image: {}x{} pixels need {} values in both images, they "
                            "hold {} and {}",
                            width, height, std::size_t(width) * std::size_t(height) * 3,
                            original.size(), model.size()));
  const double to_levels = format == SampleFormat::kHdr ? 255.0 / range : 1.0;
  Image out;
  out.width = width;
  out.height = height;
  out.rgb.resize(original.size());
  for (std::size_t i = 0; i < original.size(); ++i)
    out.rgb[i] = float(
        std::min(255.0, scale * std::abs(double(original[i]) - double(model[i])) * to_levels));
  return out;
}

Image upscale_nearest(const Image& image, int factor) {
  if (factor < 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("upscale: factor {} must be at least 1", factor));
  Image out;
  out.width = image.width * factor;
  out.height = image.height * factor;
  out.format = image.format;
  out.rgb.resize(std::size_t(out.width) * std::size_t(out.height) * 3);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int k = 0; k < 3; ++k)
        out.rgb[(std::size_t(y) * std::size_t(out.width) + std::size_t(x)) * 3 + std::size_t(k)] =
            image.rgb[(std::size_t(y / factor) * std::size_t(image.width) +
                       std::size_t(x / factor)) *
                          3 +
                      std::size_t(k)];
  return out;
}

Image mean_brdf_image(std::span<const float> mean_brdf, std::size_t lights, std::size_t views,
                      SampleFormat format) {
  if (mean_brdf.size() != lights * views * 3 || lights == 0 || views == 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("mean BRDF image: {} lights x {} views need {} values, given {}",
                            lights, views, lights * views * 3, mean_brdf.size()));
  float peak = 0.0f;
  for (float v : mean_brdf) peak = std::max(peak, v);
  const double scale = peak > 0.0f ? 1.0 / double(peak) : 1.0;
  Image out;
  out.width = int(views);
  out.height = int(lights);
  out.rgb.resize(mean_brdf.size());
  // Light-major values are already rows = lights, columns = views.
  for (std::size_t i = 0; i < mean_brdf.size(); ++i) {
    const double v = std::max(0.0, double(mean_brdf[i]) * scale);
    out.rgb[i] = float(255.0 * (format == SampleFormat::kHdr ? srgb_encode(v) : v));
  }
  return out;
}

std::array<float, 3> colour_map(double t) {
  // viridis (matplotlib), sampled at 9 points and interpolated linearly.
  static constexpr float kViridis[9][3] = {{68, 1, 84},    {71, 44, 122},  {59, 81, 139},
                                           {44, 113, 142}, {33, 144, 141}, {39, 173, 129},
                                           {92, 200, 99},  {170, 220, 50}, {253, 231, 37}};
  if (!(t > 0.0)) t = 0.0;  // also NaN
  t = std::min(t, 1.0) * 8.0;
  const int i = std::min(7, int(t));
  const float f = float(t - i);
  return {kViridis[i][0] + f * (kViridis[i + 1][0] - kViridis[i][0]),
          kViridis[i][1] + f * (kViridis[i + 1][1] - kViridis[i][1]),
          kViridis[i][2] + f * (kViridis[i + 1][2] - kViridis[i][2])};
}

std::array<double, 2> psnr_map_range(const BtfQuality& quality) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const ImageQuality& q : quality.images)
    if (std::isfinite(q.psnr_db)) {
      lo = std::min(lo, q.psnr_db);
      hi = std::max(hi, q.psnr_db);
    }
  if (!std::isfinite(lo)) return {0.0, 1.0};
  lo = std::floor(lo);
  hi = std::ceil(hi);
  if (hi <= lo) hi = lo + 1.0;
  return {lo, hi};
}

Image psnr_map_image(const BtfQuality& quality, double lo_db, double hi_db) {
  Image out;
  out.width = int(quality.views);
  out.height = int(quality.lights);
  out.rgb.resize(quality.images.size() * 3);
  const double span = hi_db > lo_db ? hi_db - lo_db : 1.0;
  for (std::size_t i = 0; i < quality.images.size(); ++i) {
    const double p = quality.images[i].psnr_db;
    const auto c = colour_map(std::isfinite(p) ? (p - lo_db) / span : 1.0);
    for (std::size_t k = 0; k < 3; ++k) out.rgb[i * 3 + k] = c[k];
  }
  return out;
}

}  // namespace btfgmm
