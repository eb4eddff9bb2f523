// RMSE, PSNR and SSIM (Wang et al. 2004); see metrics.hpp.
#include "btfgmm/measure/metrics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

namespace {

void check_image(std::span<const float> a, std::span<const float> b, int width, int height,
                 const char* what) {
  if (width < 1 || height < 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: image size {}x{} is empty; give at least 1x1 pixels", what, width,
                            height));
  const std::size_t n = std::size_t(width) * std::size_t(height) * 3;
  if (a.size() != n || b.size() != n)
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: a {}x{} RGB image needs {} values, the images hold {} and {}; "
                            "compare images of one size",
                            what, width, height, n, a.size(), b.size()));
}

void check_range(double range, const char* what) {
  if (!(range > 0.0) || !std::isfinite(range))
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the range R = {} must be a positive finite number (255 for "
                            "8-bit data)",
                            what, range));
}

// The normalised Gaussian of radius r: exp(-x^2 / (2 sigma^2)), x = -r..r, summing to 1 (as
// scipy.ndimage's _gaussian_kernel1d).
std::vector<double> gaussian_kernel(int r, double sigma) {
  std::vector<double> k(std::size_t(2 * r + 1));
  double sum = 0.0;
  for (int x = -r; x <= r; ++x) {
    const double v = std::exp(-0.5 / (sigma * sigma) * double(x) * double(x));
    k[std::size_t(x + r)] = v;
    sum += v;
  }
  for (double& v : k) v /= sum;
  return k;
}

}  // namespace

int ssim_radius(int width, int height, const SsimSettings& settings) {
  const int fit = (std::max(1, std::min(width, height)) - 1) / 2;
  return std::max(0, std::min(settings.radius, fit));
}

double ssim_channel(std::span<const float> a, std::span<const float> b, int width, int height,
                    int channel, double range, const SsimSettings& settings,
                    std::vector<double>* map) {
  check_image(a, b, width, height, "SSIM");
  check_range(range, "SSIM");
  if (channel < 0 || channel > 2)
    throw Error(Error::Kind::kArgument,
                fmt::format("SSIM: channel {} does not exist; give 0, 1 or 2 (R, G, B)", channel));
  if (!(settings.sigma > 0.0) || settings.radius < 0)
    throw Error(Error::Kind::kArgument,
                "SSIM: the window needs sigma > 0 and a radius >= 0 (Wang et al.: 1.5 and 5)");
  const int r = ssim_radius(width, height, settings);
  const std::vector<double> k = gaussian_kernel(r, settings.sigma);
  const int ow = width - 2 * r, oh = height - 2 * r;
  const std::size_t w = std::size_t(width);

  // Horizontal pass of the five moments x, y, x^2, y^2, xy over the valid columns.
  std::vector<std::array<double, 5>> rows(std::size_t(ow) * std::size_t(height));
  for (int y = 0; y < height; ++y)
    for (int ox = 0; ox < ow; ++ox) {
      std::array<double, 5> s{};
      for (int t = 0; t <= 2 * r; ++t) {
        const std::size_t i = (std::size_t(y) * w + std::size_t(ox + t)) * 3 + std::size_t(channel);
        const double x1 = double(a[i]), y1 = double(b[i]), kt = k[std::size_t(t)];
        s[0] += kt * x1;
        s[1] += kt * y1;
        s[2] += kt * (x1 * x1);
        s[3] += kt * (y1 * y1);
        s[4] += kt * (x1 * y1);
      }
      rows[std::size_t(y) * std::size_t(ow) + std::size_t(ox)] = s;
    }

  const double c1 = (settings.k1 * range) * (settings.k1 * range);
  const double c2 = (settings.k2 * range) * (settings.k2 * range);
  if (map) map->assign(std::size_t(ow) * std::size_t(oh), 0.0);
  double sum = 0.0;
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox) {
      std::array<double, 5> m{};
      for (int t = 0; t <= 2 * r; ++t) {
        const auto& s = rows[std::size_t(oy + t) * std::size_t(ow) + std::size_t(ox)];
        for (int q = 0; q < 5; ++q) m[std::size_t(q)] += k[std::size_t(t)] * s[std::size_t(q)];
      }
      const double ux = m[0], uy = m[1];
      const double vx = m[2] - ux * ux, vy = m[3] - uy * uy, vxy = m[4] - ux * uy;
      const double s =
          ((2.0 * ux * uy + c1) * (2.0 * vxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
      if (map) (*map)[std::size_t(oy) * std::size_t(ow) + std::size_t(ox)] = s;
      sum += s;
    }
  return sum / (double(ow) * double(oh));
}

double psnr_db(double rmse, double range) {
  if (rmse <= 0.0) return std::numeric_limits<double>::infinity();
  return 20.0 * std::log10(range / rmse);
}

ImageQuality image_quality(std::span<const float> original, std::span<const float> reconstruction,
                           int width, int height, double range, const SsimSettings& settings,
                           std::vector<float>* error_image) {
  check_image(original, reconstruction, width, height, "image quality");
  check_range(range, "image quality");
  ImageQuality q;
  std::array<double, 3> sq{};
  if (error_image) error_image->resize(original.size());
  for (std::size_t i = 0; i < original.size(); ++i) {
    const double d = double(original[i]) - double(reconstruction[i]);
    sq[i % 3] += d * d;
    if (error_image) (*error_image)[i] = float(std::abs(d));
  }
  const double pixels = double(width) * double(height);
  double mse = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double m = sq[std::size_t(c)] / pixels;
    mse += m / 3.0;
    q.rmse_rgb[std::size_t(c)] = std::sqrt(m);
    q.psnr_db_rgb[std::size_t(c)] = psnr_db(q.rmse_rgb[std::size_t(c)], range);
    q.ssim_rgb[std::size_t(c)] =
        ssim_channel(original, reconstruction, width, height, c, range, settings);
  }
  q.rmse = std::sqrt(mse);
  q.psnr_db = psnr_db(q.rmse, range);
  q.ssim = (q.ssim_rgb[0] + q.ssim_rgb[1] + q.ssim_rgb[2]) / 3.0;
  return q;
}

double data_range(const Btf& original) {
  if (original.format() != SampleFormat::kHdr) return 255.0;
  float peak = 0.0f;
  for (float v : original.data())
    if (std::isfinite(v)) peak = std::max(peak, v);
  return peak > 0.0f ? double(peak) : 1.0;
}

std::vector<std::size_t> BtfQuality::by_psnr() const {
  std::vector<std::size_t> order(images.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
    return images[i].psnr_db < images[j].psnr_db;
  });
  return order;
}

BtfQuality measure_quality(const Btf& original, const Btf& reconstruction, double range,
                           const SsimSettings& settings) {
  if (!(original.lights() == reconstruction.lights()) ||
      !(original.views() == reconstruction.views()))
    throw Error(Error::Kind::kArgument,
                fmt::format("quality: the original has {} x {} (light, view) directions, the "
                            "reconstruction {} x {} or other angles; decode the model at the "
                            "original's direction sets",
                            original.lights().size(), original.views().size(),
                            reconstruction.lights().size(), reconstruction.views().size()));
  if (original.width() != reconstruction.width() || original.height() != reconstruction.height())
    throw Error(Error::Kind::kArgument,
                fmt::format("quality: the original is {}x{} pixels, the reconstruction {}x{}; "
                            "decode the model at the original's size",
                            original.width(), original.height(), reconstruction.width(),
                            reconstruction.height()));
  if (range <= 0.0) range = data_range(original);
  check_range(range, "quality");

  BtfQuality out;
  out.range = range;
  out.ssim_window = 2 * ssim_radius(original.width(), original.height(), settings) + 1;
  out.lights = original.lights().size();
  out.views = original.views().size();
  out.images.resize(original.image_count());
  const std::size_t floats = original.image_floats();
  const std::ptrdiff_t count = std::ptrdiff_t(original.image_count());
  std::exception_ptr failure;
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    try {
      const std::size_t at = std::size_t(i) * floats;
      out.images[std::size_t(i)] = image_quality(
          original.data().subspan(at, floats), reconstruction.data().subspan(at, floats),
          original.width(), original.height(), range, settings);
    } catch (...) {
#pragma omp critical
      failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);

  // Every image has the same pixel count: the overall MSE is the mean of the images' MSEs.
  const double n = double(out.images.size());
  std::array<double, 3> mse{};
  for (const ImageQuality& q : out.images)
    for (std::size_t c = 0; c < 3; ++c) {
      mse[c] += q.rmse_rgb[c] * q.rmse_rgb[c] / n;
      out.ssim_rgb[c] += q.ssim_rgb[c] / n;
    }
  for (std::size_t c = 0; c < 3; ++c) {
    out.rmse_rgb[c] = std::sqrt(mse[c]);
    out.psnr_db_rgb[c] = psnr_db(out.rmse_rgb[c], range);
  }
  out.rmse = std::sqrt((mse[0] + mse[1] + mse[2]) / 3.0);
  out.psnr_db = psnr_db(out.rmse, range);
  out.ssim = (out.ssim_rgb[0] + out.ssim_rgb[1] + out.ssim_rgb[2]) / 3.0;
  for (std::size_t i = 0; i < out.images.size(); ++i) {
    const ImageQuality& q = out.images[i];
    if (q.psnr_db < out.images[out.worst_psnr].psnr_db) out.worst_psnr = i;
    if (q.psnr_db > out.images[out.best_psnr].psnr_db) out.best_psnr = i;
    if (q.ssim < out.images[out.worst_ssim].ssim) out.worst_ssim = i;
    if (q.ssim > out.images[out.best_ssim].ssim) out.best_ssim = i;
  }
  return out;
}

}  // namespace btfgmm
