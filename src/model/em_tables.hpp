// The tables of one iteration of the grid EM (em.cpp; docs/ALGORITHM.md, "The grid path"): the
// parts of Eq. (2) per pixel, light and view, the chunk bounds of the AVX-512 pass, the pixels'
// minimum-image offsets for the spatial sums; and the colour order of each block's views.
#pragma once

#include <cstdint>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/em_group_pass.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// The periods of the nine variables on the sample grid: x and y wrap around the tile
// (mixture_internal.hpp, "The tile wraps"); with `tile_wraps` false, none does (the paper's
// plain model, EmConfig::tile_wraps).
Periods tile_periods(const SampleSet& s, bool tile_wraps);

// Every table of one iteration for `mix` (Tables, em_group_pass.hpp), over `threads` threads;
// the same tables for any number of threads.
Tables make_tables(const SampleSet& s, const ProductMixture& mix, const Periods& periods,
                   int threads);

// The views of every (pixel, light) block this process holds in the order of their residual
// colours; empty where the views keep their own order.
std::vector<std::uint8_t> view_order(const SampleSet& s);

}  // namespace btfgmm::detail
