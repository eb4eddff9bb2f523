// Prediction, Eq. (8)-(11): the colour of any pixel for any light and view (whole images on
// the grid: decode.hpp).
#pragma once

#include <array>
#include <span>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

struct Query {
  double x = 0.0, y = 0.0;  // tile pixel coordinates; any real value (the tile repeats)
  Direction light, view;
};

// Predicts the RGB of every query (Eq. 11: conditional expectation of the colour plus the
// mean BRDF, interpolated between measured directions). `rgb` holds 3 floats per query.
void predict(const BtfModel& model, std::span<const Query> queries, std::span<float> rgb);
std::array<float, 3> predict(const BtfModel& model, const Query& query);

}  // namespace btfgmm
