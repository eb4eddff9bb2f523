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

// Codes of three colour planes (channel-major R, G, B, each a light x view grid of nv views
// a light, light-major) as version 5 codes the mean BRDF, shared with the texture models'
// image moments: the planes G, R - G, B - G, each code less the plane through its neighbours
// (planar_prediction, model/coded_columns.hpp); and back. Exact for any codes (the
// arithmetic wraps modulo 2^64).
std::vector<std::int64_t> predicted_colour_planes(std::vector<std::int64_t> q, std::size_t nv);
std::vector<std::int64_t> unpredicted_colour_planes(std::vector<std::int64_t> r, std::size_t nv);

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
