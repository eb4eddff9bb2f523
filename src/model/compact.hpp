// The compact encoding of the mixture's payload (docs/FORMAT.md, "The compact encoding"):
// every parameter quantised with a stated step, the codes entropy-coded with zstd.
#pragma once

#include <span>

#include "btfgmm/model/model.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// The quantisation steps of the compact encoding. A value is stored as the integer nearest
// to value / step, so the value read back is within step / 2 of the one written.
struct CompactSteps {
  double log_weight = 1.0 / 256.0;  // ln w_m (weights renormalised to sum 1 when read)
  double log_sigma = 1.0 / 512.0;   // ln sigma_mn, all nine variables (model units)
  double input_mean = 1.0 / 256.0;  // mu_mn of the six inputs, as a fraction of sigma_mn read
  double colour_mean = 1.0 / 16.0;  // mu_m7..9, model units (8-bit levels for 8-bit data)
  double mean_brdf = 1.0 / 8.0;     // the mean BRDF, in colour units (levels for 8-bit data)
};

// Writes the components and the mean BRDF of `m` in the compact encoding (from "u32 M" on).
void put_compact_components(ByteWriter& w, const BtfModel& m,
                            const CompactSteps& steps = CompactSteps());
// Reads what put_compact_components wrote into m.mixture and m.mean_brdf (m's direction sets
// and scaling already read); the rest of `r` must be exactly that. Throws Error(kFormat).
void get_compact_components(ByteReader& r, BtfModel& m);

// The model as the compact encoding stores it: its parameters rounded as a file written and
// read back would hold them (for tests and for fits that measure what they store).
BtfModel round_to_compact(const BtfModel& m);

}  // namespace btfgmm::detail
