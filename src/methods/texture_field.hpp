// An image of real values on a torus (internal): the texture models' working type
// (docs/METHODS.md, "The probabilistic texture models"). Row-major, channels interleaved;
// wrapped() reads with the indices taken modulo the size, as the models see a tileable image.
#pragma once

#include <cstddef>
#include <vector>

namespace btfgmm::detail {

struct Field {
  int width = 0, height = 0, channels = 1;
  std::vector<double> values;

  Field() = default;
  Field(int w, int h, int c)
      : width(w),
        height(h),
        channels(c),
        values(std::size_t(w) * std::size_t(h) * std::size_t(c)) {}

  std::size_t pixels() const { return std::size_t(width) * std::size_t(height); }
  std::size_t index(int x, int y, int c = 0) const {
    return (std::size_t(y) * std::size_t(width) + std::size_t(x)) * std::size_t(channels) +
           std::size_t(c);
  }
  double& at(int x, int y, int c = 0) { return values[index(x, y, c)]; }
  double at(int x, int y, int c = 0) const { return values[index(x, y, c)]; }
  // The value at (x, y) with both indices wrapped into the image: the torus.
  double wrapped(int x, int y, int c = 0) const {
    x %= width;
    y %= height;
    return at(x < 0 ? x + width : x, y < 0 ? y + height : y, c);
  }
};

// One channel of a field as a field of its own.
inline Field channel_of(const Field& f, int c) {
  Field out(f.width, f.height, 1);
  for (std::size_t i = 0; i < f.pixels(); ++i)
    out.values[i] = f.values[i * std::size_t(f.channels) + std::size_t(c)];
  return out;
}

}  // namespace btfgmm::detail
