// The largest size of one method's setting (its components, clusters or degree) whose model
// file fits a budget of bytes, found with as few fits as the file's bytes allow: each size's
// bytes predicted from the line through two sizes fitted (every method's parameter count is
// linear in its size) and confirmed with the real file. A file's bytes are not strictly
// monotone in the size (its compressed parameters vary by up to about a hundred bytes from one
// size to the next), so a search ends on two neighbouring sizes, the smaller fitting and the
// larger over the budget or refused, rather than on a proof that no larger size fits.
// choose_within_budget (budget.hpp) runs it between and above the rungs of each ladder.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>

namespace btfgmm {

// One size fitted: its file's bytes and whether they fit the budget.
struct SizeProbe {
  std::size_t size = 0;
  std::uint64_t bytes = 0;
  bool fits = false;
};

// Fits one size and returns its probe; none when the method refuses that size for the tile
// (as it then refuses every larger one).
using FitSize = std::function<std::optional<SizeProbe>(std::size_t size)>;

// At most this many sizes are fitted above a ladder's top before the search stops (the k-th at
// least 2^(k-1) sizes above the one before, so the last at least 2^16 - 1 sizes above the top).
inline constexpr int kMostSizesAbove = 16;

// Between `lo`, which fits, and `hi`, a larger size over the budget or refused (bytes 0):
// sizes predicted from the line through the two, halving when the prediction moved the same
// end twice in a row, until the two are neighbours. Returns the largest size found that fits.
SizeProbe largest_size_between(SizeProbe lo, SizeProbe hi, std::uint64_t budget,
                               const FitSize& fit);

// Above `top`, the largest rung of a ladder, which fits (`below`: the rung under it, if any):
// the size the line through `below` and the largest size that fits so far puts at the budget,
// but at least 1, 2, 4, ... sizes above that one (the step doubling with each size that fits,
// so that bytes varying from size to size do not make the search creep), until a size is over
// the budget or refused (then largest_size_between), kMostSizesAbove sizes were fitted, or
// the next size would reach `cap` (the least size known to be refused). Returns the largest
// size found that fits.
SizeProbe largest_size_above(std::optional<SizeProbe> below, SizeProbe top, std::size_t cap,
                             std::uint64_t budget, const FitSize& fit);

}  // namespace btfgmm
