// The Gaussian-Laplacian pyramid on a torus (Burt & Adelson 1983; Haindl & Filip, PAMI 2007,
// Sec. 4): REDUCE, EXPAND, decomposition and collapse.
#include "methods/pyramid.hpp"

#include <cassert>
#include <cmath>

namespace btfgmm::detail {
namespace {

// The index i wrapped into [0, n).
int wrap(int i, int n) {
  i %= n;
  return i < 0 ? i + n : i;
}

// One pass of the binomial low-pass [1 4 6 4 1] / 16 along x (horizontal) or y, wrapping.
Field binomial(const Field& f, bool horizontal) {
  static constexpr double kTaps[5] = {1 / 16.0, 4 / 16.0, 6 / 16.0, 4 / 16.0, 1 / 16.0};
  Field out(f.width, f.height, f.channels);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      for (int c = 0; c < f.channels; ++c) {
        double v = 0.0;
        for (int t = -2; t <= 2; ++t)
          v += kTaps[t + 2] *
               (horizontal ? f.at(wrap(x + t, f.width), y, c) : f.at(x, wrap(y + t, f.height), c));
        out.at(x, y, c) = v;
      }
  return out;
}

// f resampled along x (horizontal) or y to `n` pixels: the value at each new pixel's centre,
// (i + 1/2) n_old / n - 1/2 in the old pixels, interpolated linearly between the two nearest
// old pixels, wrapping.
Field resample(const Field& f, int n, bool horizontal) {
  const int old = horizontal ? f.width : f.height;
  Field out(horizontal ? n : f.width, horizontal ? f.height : n, f.channels);
  for (int i = 0; i < n; ++i) {
    const double at = (i + 0.5) * double(old) / double(n) - 0.5, lo = std::floor(at);
    const double w = at - lo;
    const int a = wrap(int(lo), old), b = wrap(int(lo) + 1, old);
    const int across = horizontal ? f.height : f.width;
    for (int j = 0; j < across; ++j)
      for (int c = 0; c < f.channels; ++c) {
        const double va = horizontal ? f.at(a, j, c) : f.at(j, a, c);
        const double vb = horizontal ? f.at(b, j, c) : f.at(j, b, c);
        (horizontal ? out.at(i, j, c) : out.at(j, i, c)) = (1 - w) * va + w * vb;
      }
  }
  return out;
}

}  // namespace

int level_side(int side, int level) {
  for (int k = 0; k < level; ++k) side = (side + 1) / 2;
  return side;
}

int max_levels(int width, int height, int min_side) {
  int levels = 1;
  while (level_side(width, levels) >= min_side && level_side(height, levels) >= min_side &&
         level_side(width, levels) < level_side(width, levels - 1))
    ++levels;
  return levels;
}

Field reduce(const Field& fine) {
  const Field blurred = binomial(binomial(fine, true), false);
  return resample(resample(blurred, level_side(fine.width, 1), true), level_side(fine.height, 1),
                  false);
}

Field expand(const Field& coarse, int width, int height) {
  return resample(resample(coarse, width, true), height, false);
}

std::vector<Field> laplacian_pyramid(const Field& image, int levels) {
  assert(levels >= 1);
  std::vector<Field> out;
  Field g = image;
  for (int k = 0; k + 1 < levels; ++k) {
    Field coarser = reduce(g);
    const Field up = expand(coarser, g.width, g.height);
    for (std::size_t i = 0; i < g.values.size(); ++i) g.values[i] -= up.values[i];
    out.push_back(std::move(g));
    g = std::move(coarser);
  }
  out.push_back(std::move(g));
  return out;
}

Field collapse(const std::vector<Field>& levels) {
  assert(!levels.empty());
  Field g = levels.back();
  for (std::size_t k = levels.size() - 1; k-- > 0;) {
    const Field& l = levels[k];
    Field up = expand(g, l.width, l.height);
    for (std::size_t i = 0; i < up.values.size(); ++i) up.values[i] += l.values[i];
    g = std::move(up);
  }
  return g;
}

}  // namespace btfgmm::detail
