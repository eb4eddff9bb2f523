// The compact encoding of a method's factors (docs/FORMAT.md, "Compact factors"): each row
// quantised with a power-of-two step stored in the file, each code predicted from its
// neighbours on the row's grid (the pixels of a spatial factor, the directions of an angular
// one), the residuals compressed with zstd.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "methods/factors.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// The compact step's bound as a fraction of a row's span: 2/255, twice q8's step, so that the
// step (a power of two) lies between q8's and twice q8's. On generated 25 x 25 tiles this loses
// at most 0.06 dB against q8 where 4/255 loses 0.14 dB (docs/METHODS.md, "Storing factors").
double compact_step_of_range();

// The step a row of values spanning [lo, hi] is quantised with: the largest power of two no
// larger than compact_step_of_range() times the span (the span is |hi| where lo = hi).
double compact_step(double lo, double hi);
// Rounds each row (cols values) to a whole multiple of its compact_step.
void quantise_compact(std::span<float> values, std::size_t cols);

// The codes after the block's header (u8 encoding, u32 rows, u32 cols): u64 coded size, u32
// compressed size, then one zstd frame of the rows' step exponents and the residual codes.
// The values must be whole multiples of a power of two each row (quantise_compact's), so
// that they are stored exactly; Error(kArgument) otherwise.
void put_compact_factors(ByteWriter& w, std::span<const float> values, std::size_t cols,
                         FactorLayout layout);
// Reads what put_compact_factors wrote for rows x cols values laid out as `layout`; a corrupted
// or truncated block fails with a message naming `field`.
std::vector<float> get_compact_factors(ByteReader& r, std::size_t rows, std::size_t cols,
                                       FactorLayout layout, const char* field);

}  // namespace btfgmm::detail
