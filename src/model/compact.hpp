// The compact encoding of the mixture's payload (docs/FORMAT.md, "The compact encoding"):
// every parameter quantised with a stated step, the codes entropy-coded with zstd.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "btfgmm/model/model.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// How the mean BRDF's codes are laid out: each channel less the one before along the views
// (version 4), or the colour differences predicted from their neighbours (version 5 on, the
// model file's flag kPredictedMeanBrdf).
enum class MeanBrdfCoding { kViewDeltas, kPredicted };

// The pieces of the encoding that other payloads share (the texture models' image moments):
// Integer codes as one column: u8 width k (bytes a code), then the codes zigzagged as k byte
// planes, the low byte first.
using Column = std::vector<std::int64_t>;
void put_column(std::vector<std::uint8_t>& out, const Column& c);
// Reads a column of n codes; r.fail() where it is malformed or runs past r.
Column get_column(ByteReader& r, std::size_t n);
// Codes of three colour planes (channel-major R, G, B, each a light x view grid of nv views
// a light, light-major) as version 5 codes the mean BRDF: the planes G, R - G, B - G, each
// code less the plane through its neighbours (lossless JPEG's predictor 4); and back.
// Exact for any codes (the arithmetic wraps modulo 2^64).
std::vector<std::int64_t> predicted_colour_planes(std::vector<std::int64_t> q, std::size_t nv);
std::vector<std::int64_t> unpredicted_colour_planes(std::vector<std::int64_t> r, std::size_t nv);
// One zstd frame of `raw` (level 19); throws Error(kIo) where zstd fails.
std::vector<std::uint8_t> compress_codes(const std::vector<std::uint8_t>& raw);
// The raw_size bytes in the zstd frame `packed`: r.fail() where the frame states another
// size, claims more than a frame of its size can hold (checked before allocating) or is
// corrupted.
std::vector<std::uint8_t> decompress_codes(ByteReader& r, std::span<const std::uint8_t> packed,
                                           std::uint64_t raw_size);

// Writes the components and the mean BRDF of `m` in the compact encoding (from "u32 M" on),
// with m.compact_steps and the predicted mean BRDF.
void put_compact_components(ByteWriter& w, const BtfModel& m);
// Reads what put_compact_components wrote (or a version-4 file's, kViewDeltas) into m.mixture,
// m.mean_brdf and m.compact_steps (m's direction sets and scaling already read); the rest of
// `r` must be exactly that. Throws Error(kFormat).
void get_compact_components(ByteReader& r, BtfModel& m, MeanBrdfCoding coding);

// The model as the compact encoding stores it with m.compact_steps: its parameters rounded as
// a file written and read back would hold them (for tests and for fits that measure what they
// store).
BtfModel round_to_compact(const BtfModel& m);

}  // namespace btfgmm::detail
