// Statistics of synthesised texture against its data (texture_statistics.hpp): moments,
// histograms and autocorrelations, as Haindl & Filip (PAMI 2007) judge their models by
// appearance rather than by pixels.
#include "btfgmm/measure/texture_statistics.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

namespace btfgmm {
namespace {

constexpr int kBins = 32;

struct ImageStats {
  std::array<double, 3> mean{}, deviation{};
  std::vector<double> luminance;
};

ImageStats image_stats(const float* rgb, std::size_t pixels) {
  ImageStats s;
  s.luminance.resize(pixels);
  for (std::size_t p = 0; p < pixels; ++p) {
    for (std::size_t c = 0; c < 3; ++c) s.mean[c] += rgb[p * 3 + c];
    s.luminance[p] = (double(rgb[p * 3]) + rgb[p * 3 + 1] + rgb[p * 3 + 2]) / 3.0;
  }
  for (double& m : s.mean) m /= double(pixels);
  for (std::size_t p = 0; p < pixels; ++p)
    for (std::size_t c = 0; c < 3; ++c) s.deviation[c] += std::pow(rgb[p * 3 + c] - s.mean[c], 2);
  for (double& d : s.deviation) d = std::sqrt(d / double(pixels));
  return s;
}

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

// rho(dx, dy) for |dx|, |dy| <= lag, on the torus, (2 lag + 1)^2 values.
std::vector<double> autocorrelation(const std::vector<double>& v, int w, int h, int lag) {
  double m = 0, var = 0;
  for (double x : v) m += x;
  m /= double(v.size());
  for (double x : v) var += (x - m) * (x - m);
  std::vector<double> rho;
  for (int dy = -lag; dy <= lag; ++dy)
    for (int dx = -lag; dx <= lag; ++dx) {
      double s = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          s += (v[std::size_t(y * w + x)] - m) *
               (v[std::size_t(((y + dy) % h + h) % h * w + ((x + dx) % w + w) % w)] - m);
      rho.push_back(var > 0 ? s / var : 0.0);
    }
  return rho;
}

}  // namespace

TextureStatistics texture_statistics(const Btf& data, const Btf& model, int max_lag) {
  assert(data.image_count() == model.image_count() && data.width() == model.width() &&
         data.height() == model.height());
  TextureStatistics t;
  t.max_lag = std::min({max_lag, (data.width() - 1) / 2, (data.height() - 1) / 2});
  const std::size_t pixels = std::size_t(data.width()) * std::size_t(data.height());
  const double n = double(data.image_count());
  for (std::size_t i = 0; i < data.image_count(); ++i) {
    const ImageStats d = image_stats(data.data().data() + i * data.image_floats(), pixels);
    const ImageStats m = image_stats(model.data().data() + i * model.image_floats(), pixels);
    for (std::size_t c = 0; c < 3; ++c) {
      t.data_mean[c] += d.mean[c] / n, t.model_mean[c] += m.mean[c] / n;
      t.data_deviation[c] += d.deviation[c] / n, t.model_deviation[c] += m.deviation[c] / n;
      t.mean_difference += std::abs(m.mean[c] - d.mean[c]) / (3 * n);
      t.deviation_difference += std::abs(m.deviation[c] - d.deviation[c]) / (3 * n);
    }
    t.histogram_distance += histogram_distance(d.luminance, m.luminance) / n;
    const auto rd = autocorrelation(d.luminance, data.width(), data.height(), t.max_lag);
    const auto rm = autocorrelation(m.luminance, data.width(), data.height(), t.max_lag);
    double diff = 0;
    for (std::size_t k = 0; k < rd.size(); ++k) diff += std::abs(rm[k] - rd[k]);
    if (rd.size() > 1) t.autocorrelation_difference += diff / double(rd.size() - 1) / n;
  }
  return t;
}

}  // namespace btfgmm
