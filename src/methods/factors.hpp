// Storing a method's real factors in the model file as compactly as their precision needs
// (docs/FORMAT.md, "Factors"), and the frame every method's payload starts with.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/methods/representation.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// Where a row's values have neighbours, for the compact encoding's prediction: `channels`
// values interleaved (3: RGB), each channel a grid `across` values wide (an image's width; the
// views of a light x view grid); across 0: the row is one line (the lights of a view).
struct FactorLayout {
  std::size_t across = 0, channels = 1;
};

// The neighbours of a factor's values for the compact encoding: an image of the frame (RGB
// interleaved, rows `width` pixels), or the light x view grid (`channels` values a pair).
FactorLayout image_layout(const ModelFrame& f);
FactorLayout directions_layout(const ModelFrame& f, std::size_t channels);

// The largest error quantise_factors can leave in a value of a row whose values span
// [lo, hi] (q8: half a step of (hi - lo) / 255; compact: half its compact_step, at most as
// much as q8's; f16: 2^-11 relative; f32: none).
double factor_error_bound(FactorEncoding e, double lo, double hi);

// Rounds `values` (rows x cols, row-major; a row is one component) to what `e` stores, so
// that a model in memory equals the model read back from its file, bit for bit. Throws
// Error(kArgument) for a value that is not finite.
void quantise_factors(std::span<float> values, std::size_t cols, FactorEncoding e);

// Writes rows x cols values (already quantised) as: u8 encoding, u32 rows, u32 cols, then
// f32 | f16 values, or per row an f32 offset and f32 scale followed by cols u8 codes
// (value = offset + scale * code), or the compact block (methods/compact_factors.hpp), whose
// prediction follows `layout`.
void put_factors(ByteWriter& w, std::span<const float> values, std::size_t cols, FactorEncoding e,
                 FactorLayout layout = {});
// Reads what put_factors wrote, expecting rows x cols values laid out as `layout`; a
// different shape, an unknown encoding, a non-finite value, a corrupted compact block or too
// few bytes fail with a message naming `field`.
std::vector<float> get_factors(ByteReader& r, std::size_t rows, std::size_t cols, const char* field,
                               FactorLayout layout = {});
// Bytes put_factors writes for rows x cols values in a fixed-size encoding (f32, f16, q8);
// the compact block's size is known once coded (Error(kArgument)).
std::size_t factor_bytes(std::size_t rows, std::size_t cols, FactorEncoding e);

// The frame: tile size, origin, sample format, light and view directions (the layout of the
// mixture's version-1 payload, docs/FORMAT.md).
void put_frame(ByteWriter& w, const ModelFrame& f);
ModelFrame get_frame(ByteReader& r);

// A u32 count that must lie in [lo, hi]; otherwise r.fail() naming `field`.
std::size_t get_count(ByteReader& r, std::size_t lo, std::size_t hi, const char* field);

}  // namespace btfgmm::detail
