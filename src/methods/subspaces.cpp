// The BTF subspaces (Haindl & Filip, PAMI 2007): k-means over image features.
#include "methods/subspaces.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/random.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::size_t kFeatures = 8;
using Features = std::array<double, kFeatures>;

Features image_features(const Btf& t, std::size_t image) {
  const float* p = t.data().data() + image * t.image_floats();
  const int w = t.width(), h = t.height();
  const std::size_t n = std::size_t(w) * std::size_t(h);
  Features f{};
  std::vector<double> lum(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < 3; ++c)
      f[c] += p[i * 3 + c], f[3 + c] += double(p[i * 3 + c]) * p[i * 3 + c];
    lum[i] = (double(p[i * 3]) + p[i * 3 + 1] + p[i * 3 + 2]) / 3.0;
  }
  for (std::size_t c = 0; c < 3; ++c) {
    f[c] /= double(n);
    f[3 + c] = std::sqrt(std::max(f[3 + c] / double(n) - f[c] * f[c], 0.0));
  }
  double m = 0, var = 0, right = 0, down = 0;
  for (double v : lum) m += v;
  m /= double(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = lum[std::size_t(y * w + x)] - m;
      var += v * v;
      right += v * (lum[std::size_t(y * w + (x + 1) % w)] - m);
      down += v * (lum[std::size_t(((y + 1) % h) * w + x)] - m);
    }
  f[6] = var > 0 ? right / var : 0.0;
  f[7] = var > 0 ? down / var : 0.0;
  return f;
}

void standardise(std::vector<Features>& fs) {
  for (std::size_t k = 0; k < kFeatures; ++k) {
    double m = 0, s = 0;
    for (const auto& f : fs) m += f[k];
    m /= double(fs.size());
    for (const auto& f : fs) s += (f[k] - m) * (f[k] - m);
    s = std::sqrt(s / double(fs.size()));
    for (auto& f : fs) f[k] = s > 1e-12 ? (f[k] - m) / s : 0.0;
  }
}

double distance2(const Features& a, const Features& b) {
  double d = 0;
  for (std::size_t k = 0; k < kFeatures; ++k) d += (a[k] - b[k]) * (a[k] - b[k]);
  return d;
}

// k-means++ (Arthur & Vassilvitskii 2007): each next centre drawn with probability
// proportional to the squared distance to the nearest chosen one.
std::vector<Features> seed_centres(const std::vector<Features>& fs, std::size_t c,
                                   std::uint64_t seed) {
  SplitMix64 rng(mix64(seed ^ 0x7375627370616365ULL));
  std::vector<Features> centres = {fs[std::size_t(rng.uniform() * double(fs.size()))]};
  std::vector<double> d(fs.size(), std::numeric_limits<double>::max());
  while (centres.size() < c) {
    double total = 0;
    for (std::size_t i = 0; i < fs.size(); ++i)
      total += d[i] = std::min(d[i], distance2(fs[i], centres.back()));
    if (total <= 0) break;
    double u = rng.uniform() * total;
    std::size_t pick = 0;
    while (pick + 1 < fs.size() && (u -= d[pick]) > 0) ++pick;
    centres.push_back(fs[pick]);
  }
  return centres;
}

std::vector<std::size_t> assign(const std::vector<Features>& fs,
                                const std::vector<Features>& centres) {
  std::vector<std::size_t> label(fs.size());
  for (std::size_t i = 0; i < fs.size(); ++i) {
    double best = std::numeric_limits<double>::max();
    for (std::size_t k = 0; k < centres.size(); ++k)
      if (const double d = distance2(fs[i], centres[k]); d < best) best = d, label[i] = k;
  }
  return label;
}

}  // namespace

Subspaces cluster_images(const Btf& tile, std::size_t c, std::uint64_t seed) {
  std::vector<Features> fs(tile.image_count());
  for (std::size_t i = 0; i < fs.size(); ++i) fs[i] = image_features(tile, i);
  standardise(fs);
  std::vector<Features> centres = seed_centres(fs, std::min(c, fs.size()), seed);
  std::vector<std::size_t> label = assign(fs, centres);
  for (int round = 0; round < 50; ++round) {
    std::vector<Features> sum(centres.size(), Features{});
    std::vector<std::size_t> count(centres.size(), 0);
    for (std::size_t i = 0; i < fs.size(); ++i) {
      for (std::size_t k = 0; k < kFeatures; ++k) sum[label[i]][k] += fs[i][k];
      ++count[label[i]];
    }
    for (std::size_t j = 0; j < centres.size(); ++j)
      if (count[j])
        for (std::size_t k = 0; k < kFeatures; ++k) centres[j][k] = sum[j][k] / double(count[j]);
    const std::vector<std::size_t> next = assign(fs, centres);
    if (next == label) break;
    label = next;
  }
  // Drop empty clusters, renumber, and take each one's member nearest its centre.
  Subspaces s;
  std::vector<int> renumber(centres.size(), -1);
  s.labels.resize(fs.size());
  for (std::size_t i = 0; i < fs.size(); ++i) {
    int& r = renumber[label[i]];
    if (r < 0) r = int(s.representatives.size()), s.representatives.push_back(i);
    s.labels[i] = std::uint8_t(r);
    const std::size_t rep = s.representatives[std::size_t(r)];
    if (distance2(fs[i], centres[label[i]]) < distance2(fs[rep], centres[label[i]]))
      s.representatives[std::size_t(r)] = i;
  }
  return s;
}

}  // namespace btfgmm::detail
