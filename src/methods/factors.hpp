// Storing a method's real factors in the model file as compactly as their precision needs
// (docs/FORMAT.md, "Factors"), and the frame every method's payload starts with.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/methods/representation.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// The largest error quantise_factors can leave in a value of a row whose values span
// [lo, hi] (q8: half a step of (hi - lo) / 255; f16: 2^-11 relative; f32: none).
double factor_error_bound(FactorEncoding e, double lo, double hi);

// Rounds `values` (rows x cols, row-major; a row is one component) to what `e` stores, so
// that a model in memory equals the model read back from its file, bit for bit. Throws
// Error(kArgument) for a value that is not finite.
void quantise_factors(std::span<float> values, std::size_t cols, FactorEncoding e);

// Writes rows x cols values (already quantised) as: u8 encoding, u32 rows, u32 cols, then
// f32 | f16 values, or per row an f32 offset and f32 scale followed by cols u8 codes
// (value = offset + scale * code).
void put_factors(ByteWriter& w, std::span<const float> values, std::size_t cols, FactorEncoding e);
// Reads what put_factors wrote, expecting rows x cols values; a different shape, an unknown
// encoding, a non-finite value or too few bytes fail with a message naming `field`.
std::vector<float> get_factors(ByteReader& r, std::size_t rows, std::size_t cols,
                               const char* field);
// Bytes put_factors writes for rows x cols values.
std::size_t factor_bytes(std::size_t rows, std::size_t cols, FactorEncoding e);

// The frame: tile size, origin, sample format, light and view directions (the layout of the
// mixture's version-1 payload, docs/FORMAT.md).
void put_frame(ByteWriter& w, const ModelFrame& f);
ModelFrame get_frame(ByteReader& r);

// A u32 count that must lie in [lo, hi]; otherwise r.fail() naming `field`.
std::size_t get_count(ByteReader& r, std::size_t lo, std::size_t hi, const char* field);

}  // namespace btfgmm::detail
