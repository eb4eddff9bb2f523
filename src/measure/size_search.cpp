// The largest size whose model file fits a budget; see size_search.hpp.
#include "btfgmm/measure/size_search.hpp"

#include <algorithm>
#include <cmath>

namespace btfgmm {

namespace {

// The slope of the line through `lo` and `hi` (a larger size with more bytes than lo's).
double bytes_per_size(const SizeProbe& lo, const SizeProbe& hi) {
  return double(hi.bytes - lo.bytes) / double(hi.size - lo.size);
}

// The size the line through `lo` and `hi` puts at the budget.
std::size_t size_at_budget(const SizeProbe& lo, const SizeProbe& hi, std::uint64_t budget) {
  return lo.size + std::size_t(std::floor(double(budget - lo.bytes) / bytes_per_size(lo, hi)));
}

// Above `top`: the line through `below` and `top` at the budget, at least one more than top;
// twice top when there is no `below` or the bytes did not grow.
std::size_t predicted_size_above(const std::optional<SizeProbe>& below, const SizeProbe& top,
                                 std::uint64_t budget) {
  if (!below || top.bytes <= below->bytes) return 2 * top.size;
  return top.size + std::max<std::size_t>(
                        1, std::size_t(double(budget - top.bytes) / bytes_per_size(*below, top)));
}

}  // namespace

SizeProbe largest_size_between(SizeProbe lo, SizeProbe hi, std::uint64_t budget,
                               const FitSize& fit) {
  int last = 0;        // the end the last fit moved: 1 the one that fits, 2 the other
  bool twice = false;  // it moved twice in a row: the prediction is off, halve instead
  while (hi.size - lo.size > 1) {
    std::size_t size = lo.size + (hi.size - lo.size) / 2;
    if (hi.bytes > lo.bytes && !twice) size = size_at_budget(lo, hi, budget);
    size = std::clamp(size, lo.size + 1, hi.size - 1);
    const std::optional<SizeProbe> p = fit(size);
    if (!p) {  // refused for the tile, as every larger size is: no bytes, so halve below it
      hi = SizeProbe{.size = size};
      continue;
    }
    (p->fits ? lo : hi) = *p;
    twice = (p->fits ? 1 : 2) == last;
    last = p->fits ? 1 : 2;
  }
  return lo;
}

SizeProbe largest_size_above(std::optional<SizeProbe> below, SizeProbe top, std::size_t cap,
                             std::uint64_t budget, const FitSize& fit) {
  std::size_t least_step = 1;
  for (int tries = 0; tries < kMostSizesAbove && top.size + 1 < cap; ++tries) {
    const std::size_t size = std::min(
        std::max(predicted_size_above(below, top, budget), top.size + least_step), cap - 1);
    const std::optional<SizeProbe> p = fit(size);
    if (!p) return largest_size_between(top, SizeProbe{.size = size}, budget, fit);
    if (!p->fits) return largest_size_between(top, *p, budget, fit);
    // `below` stays: the slope is taken over the widest span fitted, which the bytes' variation
    // from one size to the next moves least.
    top = *p;
    least_step *= 2;
  }
  return top;
}

}  // namespace btfgmm
