// How visible a tile's wrap and cut are (include/btfgmm/measure/seamless_tile.hpp,
// wrap_statistics): per image, the mean |step| across the wrap over the mean |step| inside,
// and the high percentile of the steps of the tile repeated 2 x 2 against the data's own.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/measure/seamless_tile.hpp"

namespace btfgmm {
namespace {

// Light-major indices of `count` pairs spread over those whose view is at most 60 degrees from
// the normal: the k-th of n at floor(k (n - 1) / (count - 1)).
std::vector<std::size_t> judged_pairs(const BtfInfo& info, std::size_t count) {
  std::vector<std::size_t> eligible;
  const std::size_t nv = info.views.size();
  for (std::size_t i = 0; i < info.lights.size() * nv; ++i)
    if (info.views[i % nv].theta_deg <= 60.0 + 1e-9) eligible.push_back(i);
  if (count == 0 || count >= eligible.size() || count < 2) return eligible;
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < count; ++k)
    out.push_back(eligible[(k * (eligible.size() - 1)) / (count - 1)]);
  return out;
}

// One RGB image, w x h.
struct Picture {
  int w = 0, h = 0;
  std::vector<float> rgb;
  float at(int x, int y, int c) const {
    return rgb[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3 + std::size_t(c)];
  }
};

Picture read_picture(const BtfSource& s, const Tile& tile, std::size_t i) {
  Picture p;
  const Tile t = tile.or_whole(s.info().width, s.info().height);
  p.w = t.width;
  p.h = t.height;
  s.read_tiles(t, i, i + 1, [&](std::size_t, std::span<const float> rgb) {
    p.rgb.assign(rgb.begin(), rgb.end());
  });
  return p;
}

// The mean |step| across the wrap over the mean |step| inside, both directions averaged.
double wrap_ratio(const Picture& p) {
  double ix = 0, iy = 0, wx = 0, wy = 0;
  for (int y = 0; y < p.h; ++y)
    for (int x = 0; x < p.w; ++x)
      for (int c = 0; c < 3; ++c) {
        if (x + 1 < p.w) ix += std::abs(p.at(x + 1, y, c) - p.at(x, y, c));
        if (y + 1 < p.h) iy += std::abs(p.at(x, y + 1, c) - p.at(x, y, c));
      }
  for (int y = 0; y < p.h; ++y)
    for (int c = 0; c < 3; ++c) wx += std::abs(p.at(0, y, c) - p.at(p.w - 1, y, c));
  for (int x = 0; x < p.w; ++x)
    for (int c = 0; c < 3; ++c) wy += std::abs(p.at(x, 0, c) - p.at(x, p.h - 1, c));
  ix /= 3.0 * (p.w - 1) * p.h;
  iy /= 3.0 * (p.h - 1) * p.w;
  wx /= 3.0 * p.h;
  wy /= 3.0 * p.w;
  return 0.5 * (wx / std::max(ix, 1e-6) + wy / std::max(iy, 1e-6));
}

// Adds to `sum` (w - 1) x (h - 1) the mean |step| of each pixel of `p` repeated rx x ry
// times to its right and lower neighbours (wrapping), the last row and column left out.
void add_steps(const Picture& p, int rx, int ry, std::vector<double>& sum) {
  const int W = p.w * rx, H = p.h * ry;
  sum.resize(std::size_t(W - 1) * std::size_t(H - 1), 0.0);
  for (int y = 0; y + 1 < H; ++y)
    for (int x = 0; x + 1 < W; ++x) {
      double right = 0, down = 0;
      for (int c = 0; c < 3; ++c) {
        const float v = p.at(x % p.w, y % p.h, c);
        right += std::abs(p.at((x + 1) % p.w, y % p.h, c) - v);
        down += std::abs(p.at(x % p.w, (y + 1) % p.h, c) - v);
      }
      sum[std::size_t(y) * std::size_t(W - 1) + std::size_t(x)] += 0.5 * (right + down) / 3.0;
    }
}

// The q-th percentile, interpolated between the order statistics (as numpy's default).
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q / 100.0 * double(v.size() - 1);
  const std::size_t lo = std::size_t(std::floor(pos));
  const std::size_t hi = std::min(v.size() - 1, lo + 1);
  return v[lo] + (pos - double(lo)) * (v[hi] - v[lo]);
}

}  // namespace

WrapStatistics wrap_statistics(const BtfSource& source, const Tile& tile, std::size_t images,
                               const BtfSource* reference) {
  const Tile t = tile.or_whole(source.info().width, source.info().height);
  if (t.width < 2 || t.height < 2)
    throw Error(Error::Kind::kArgument,
                fmt::format("a {}x{} tile has no interior step to judge its wrap by; give at "
                            "least 2x2",
                            t.width, t.height));
  const std::vector<std::size_t> pairs = judged_pairs(source.info(), images);
  std::vector<double> ratios, tiled, own;
  for (std::size_t i : pairs) {
    const Picture p = read_picture(source, t, i);
    ratios.push_back(wrap_ratio(p));
    if (!reference) continue;
    add_steps(p, 2, 2, tiled);
    Picture r = read_picture(*reference, {}, i);
    add_steps(r, 1, 1, own);
  }
  WrapStatistics s;
  s.images = ratios.size();
  s.median_ratio = percentile(ratios, 50.0);
  s.p90_ratio = percentile(ratios, 90.0);
  if (reference) s.cut_ratio = percentile(tiled, 99.0) / std::max(percentile(own, 99.0), 1e-9);
  return s;
}

}  // namespace btfgmm
