// Decoding, Eq. (8)-(11) on the grid: whole images of a model for any light and view sets.
#pragma once

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

// decode()'s default tolerance, levels: a thousandth of an 8-bit level.
constexpr double kDecodeTolerance = 1e-3;

// Decodes images of width x height pixels (the tile repeated) for every pair of the given
// light and view sets, on the grid-factored form of Eq. (9) (docs/ALGORITHM.md, "Decoding").
// Components whose weight is bounded so low over a block of pixels that all of them together
// move no value by more than `tolerance` levels (of the data's scale) are skipped; 0 keeps
// every component. The result equals predict()'s within tolerance + 1e-3 levels. Throws
// Error(kArgument) for a direction off the hemisphere or a negative tolerance.
Btf decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views, int width,
           int height, double tolerance = kDecodeTolerance);

}  // namespace btfgmm
