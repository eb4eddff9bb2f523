// Integer codes as the compact encodings store them (docs/FORMAT.md, "The compact encoding"):
// zigzagged, split into byte planes per column, and compressed with zstd.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "model/byte_io.hpp"

namespace btfgmm::detail {

using CodeColumn = std::vector<std::int64_t>;

// Signed codes as unsigned ones, small magnitudes small: 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...
std::uint64_t zigzag(std::int64_t v);
std::int64_t unzigzag(std::uint64_t z);

// Sums and differences of codes that wrap modulo 2^64, so that a file's codes, however large,
// are undone exactly and with no overflow (a reader meets corrupted files).
std::int64_t wrapping_plus(std::int64_t a, std::int64_t b);
std::int64_t wrapping_minus(std::int64_t a, std::int64_t b);

// The plane through the three neighbours of code i on a grid `across` codes wide (a light x
// view grid, an image's rows; lossless JPEG's predictor 4, ITU-T T.81 Table H.1): a + b - c
// from the code before along the row (a), the one above (b) and the one before both (c); at
// the grid's first row and column the neighbours missing are a (and a is b, or 0, at the first
// code of a row), so the prediction there is a.
std::int64_t planar_prediction(std::span<const std::int64_t> p, std::size_t i, std::size_t across);

// One column: u8 width k (bytes per code, the fewest that hold every zigzagged code), then k
// byte planes of n bytes, the low byte first.
void put_column(std::vector<std::uint8_t>& out, std::span<const std::int64_t> c);
// Reads n codes that put_column wrote; r.fail() for a bad width or too few bytes.
CodeColumn get_column(ByteReader& r, std::size_t n);

// `raw` compressed as one zstd frame (level 19). Throws Error(kIo) if zstd fails.
std::vector<std::uint8_t> zstd_pack(std::span<const std::uint8_t> raw);
// The `raw_size` bytes a zstd frame holds: r.fail() (naming the file that r reads) when the
// frame states another size, could not hold that many bytes, or is corrupted.
std::vector<std::uint8_t> zstd_unpack(const ByteReader& r, std::span<const std::uint8_t> packed,
                                      std::uint64_t raw_size);

}  // namespace btfgmm::detail
