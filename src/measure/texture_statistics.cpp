// Statistics of synthesised texture against its data (texture_statistics.hpp): moments,
// histograms, autocorrelations, saturation and streaks, as Haindl & Filip (PAMI 2007) judge
// their models by appearance rather than by pixels.
#include "btfgmm/measure/texture_statistics.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

namespace btfgmm {
namespace {

constexpr int kBins = 32;

// Total variation between the two luminance histograms over the data's range.
double histogram_distance(const std::vector<double>& data, const std::vector<double>& model) {
  const auto range = std::minmax_element(data.begin(), data.end());
  const double lo = *range.first, width = std::max(*range.second - lo, 1e-9) / kBins;
  std::array<double, kBins> a{}, b{};
  const auto bin = [&](double v) { return std::clamp(int((v - lo) / width), 0, kBins - 1); };
  for (double v : data) a[std::size_t(bin(v))] += 1.0 / double(data.size());
  for (double v : model) b[std::size_t(bin(v))] += 1.0 / double(model.size());
  double d = 0;
  for (int k = 0; k < kBins; ++k) d += std::abs(a[std::size_t(k)] - b[std::size_t(k)]);
  return d / 2;
}

// rho(dx, dy) of the luminance on the torus, normalised by its variance.
double autocorrelation(const std::vector<double>& v, double mean, double variance, int w, int h,
                       int dx, int dy) {
  if (variance <= 0) return 0.0;
  double s = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      s += (v[std::size_t(y * w + x)] - mean) *
           (v[std::size_t((y + dy) % h * w + (x + dx) % w)] - mean);
  return s / variance;
}

// The largest jump between neighbouring column means (`columns`) or row means, wrapping.
double largest_jump(const std::vector<double>& v, int w, int h, bool columns) {
  const int n = columns ? w : h;
  std::vector<double> means(std::size_t(n), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) means[std::size_t(columns ? x : y)] += v[std::size_t(y * w + x)];
  for (double& m : means) m /= double(columns ? h : w);
  double jump = 0;
  for (int i = 0; i < n; ++i)
    jump = std::max(jump, std::abs(means[std::size_t(i)] - means[std::size_t((i + 1) % n)]));
  return jump;
}

}  // namespace

TextureImageStatistics texture_image_statistics(std::span<const float> rgb, int width, int height) {
  TextureImageStatistics s;
  s.width = width, s.height = height;
  const std::size_t pixels = std::size_t(width) * std::size_t(height);
  assert(rgb.size() == pixels * 3);
  s.luminance.resize(pixels);
  std::size_t saturated = 0;
  for (std::size_t p = 0; p < pixels; ++p) {
    for (std::size_t c = 0; c < 3; ++c) {
      s.mean[c] += rgb[p * 3 + c];
      saturated += rgb[p * 3 + c] <= 0.5f || rgb[p * 3 + c] >= 254.5f;
    }
    s.luminance[p] = (double(rgb[p * 3]) + rgb[p * 3 + 1] + rgb[p * 3 + 2]) / 3.0;
  }
  s.saturated = double(saturated) / double(pixels * 3);
  for (double& m : s.mean) m /= double(pixels);
  for (std::size_t p = 0; p < pixels; ++p)
    for (std::size_t c = 0; c < 3; ++c) s.deviation[c] += std::pow(rgb[p * 3 + c] - s.mean[c], 2);
  for (double& d : s.deviation) d = std::sqrt(d / double(pixels));
  double m = 0, var = 0;
  for (double v : s.luminance) m += v;
  m /= double(pixels);
  for (double v : s.luminance) var += (v - m) * (v - m);
  for (int k = 1; k <= kTextureLags; ++k) {
    s.rho_x[std::size_t(k - 1)] = autocorrelation(s.luminance, m, var, width, height, k, 0);
    s.rho_y[std::size_t(k - 1)] = autocorrelation(s.luminance, m, var, width, height, 0, k);
  }
  s.streak = std::max(largest_jump(s.luminance, width, height, true),
                      largest_jump(s.luminance, width, height, false));
  return s;
}

TextureImageComparison compare_texture_images(const TextureImageStatistics& data,
                                              const TextureImageStatistics& model) {
  TextureImageComparison c;
  for (std::size_t k = 0; k < 3; ++k) {
    c.mean_difference[k] = model.mean[k] - data.mean[k];
    c.deviation_ratio[k] = data.deviation[k] > 0    ? model.deviation[k] / data.deviation[k]
                           : model.deviation[k] > 0 ? 1e9
                                                    : 1.0;
  }
  for (std::size_t k = 0; k < std::size_t(kTextureLags); ++k)
    c.autocorrelation_difference =
        std::max({c.autocorrelation_difference, std::abs(model.rho_x[k] - data.rho_x[k]),
                  std::abs(model.rho_y[k] - data.rho_y[k])});
  c.histogram_distance = histogram_distance(data.luminance, model.luminance);
  c.streak_ratio = model.streak / std::max(data.streak, 1e-6);
  c.saturated_data = data.saturated, c.saturated_model = model.saturated;
  return c;
}

TextureStatistics summarise_texture(std::span<const TextureImageComparison> images,
                                    std::span<const TextureImageStatistics> data,
                                    std::span<const TextureImageStatistics> model) {
  TextureStatistics t;
  const double n = double(images.size());
  t.lowest_deviation_ratio = 1e300, t.highest_deviation_ratio = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const TextureImageComparison& c = images[i];
    for (std::size_t k = 0; k < 3; ++k) {
      t.data_mean[k] += data[i].mean[k] / n, t.model_mean[k] += model[i].mean[k] / n;
      t.data_deviation[k] += data[i].deviation[k] / n;
      t.model_deviation[k] += model[i].deviation[k] / n;
      t.mean_difference += std::abs(c.mean_difference[k]) / (3 * n);
      t.deviation_difference += std::abs(model[i].deviation[k] - data[i].deviation[k]) / (3 * n);
      t.worst_mean_difference = std::max(t.worst_mean_difference, std::abs(c.mean_difference[k]));
      t.lowest_deviation_ratio = std::min(t.lowest_deviation_ratio, c.deviation_ratio[k]);
      t.highest_deviation_ratio = std::max(t.highest_deviation_ratio, c.deviation_ratio[k]);
    }
    double rho = 0;
    for (std::size_t k = 0; k < std::size_t(kTextureLags); ++k)
      rho += std::abs(model[i].rho_x[k] - data[i].rho_x[k]) +
             std::abs(model[i].rho_y[k] - data[i].rho_y[k]);
    t.autocorrelation_difference += rho / (2 * kTextureLags) / n;
    t.worst_autocorrelation_difference =
        std::max(t.worst_autocorrelation_difference, c.autocorrelation_difference);
    t.histogram_distance += c.histogram_distance / n;
    t.worst_streak_ratio = std::max(t.worst_streak_ratio, c.streak_ratio);
    t.saturated_data += c.saturated_data / n, t.saturated_model += c.saturated_model / n;
  }
  if (images.empty()) t.lowest_deviation_ratio = t.highest_deviation_ratio = 1;
  return t;
}

TextureStatistics texture_statistics(const Btf& data, const Btf& model) {
  assert(data.image_count() == model.image_count());
  std::vector<TextureImageStatistics> d(data.image_count()), m(data.image_count());
  std::vector<TextureImageComparison> c(data.image_count());
#pragma omp parallel for schedule(dynamic, 16)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(data.image_count()); ++i) {
    const std::size_t k = std::size_t(i);
    d[k] = texture_image_statistics(
        {data.data().data() + k * data.image_floats(), data.image_floats()}, data.width(),
        data.height());
    m[k] = texture_image_statistics(
        {model.data().data() + k * model.image_floats(), model.image_floats()}, model.width(),
        model.height());
    c[k] = compare_texture_images(d[k], m[k]);
    d[k].luminance.clear(), m[k].luminance.clear();
    d[k].luminance.shrink_to_fit(), m[k].luminance.shrink_to_fit();
  }
  return summarise_texture(c, d, m);
}

}  // namespace btfgmm
