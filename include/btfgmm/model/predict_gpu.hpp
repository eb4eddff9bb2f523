// Prediction, Eq. (8)-(11), on a compute device (docs/GPU.md, "Decoding on the GPU"): the
// sums of predict() and decode() made by the shader predict_colours.comp, every component
// weighed, in float; the mean BRDF of Eq. (11) added on the host.
#pragma once

#include <cstddef>
#include <span>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"

namespace btfgmm {

// predict() on `device`: the RGB of every query (3 floats a query in `rgb`), within a
// thousandth of a level of predict()'s double sums (tests: 1.6e-5 on lavapipe). Throws
// Error(kArgument) for a query off the hemisphere or not finite, or more than 2^32 - 1
// queries, and Error(kIo) for a device fault, naming `device` cpu.
void predict(ComputeDevice& device, const BtfModel& model, std::span<const Query> queries,
             std::span<float> rgb);

// The queries one run of the device computes at most: 4 Mi, their colours 48 MiB.
inline constexpr std::size_t kGpuDecodeQueries = std::size_t(1) << 22;

// decode() on `device`, every component weighed (decode's tolerance 0): images of width x
// height pixels (the tile repeated) for every pair of the given sets, each tile pixel of each
// image one query, `queries_per_run` (>= 1) at most in one run of the device.
Btf decode(ComputeDevice& device, const BtfModel& model, const DirectionSet& lights,
           const DirectionSet& views, int width, int height,
           std::size_t queries_per_run = kGpuDecodeQueries);

}  // namespace btfgmm
