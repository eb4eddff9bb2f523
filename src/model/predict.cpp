// Prediction, Eq. (8)-(11), one query at a time in double: the conditional weights W_m(x_I) of
// the six inputs (Eq. 9-10), the conditional expectation of the colour sum_m W_m mu_m,7..9
// (Eq. 8 integrated), plus the mean BRDF (Eq. 11), interpolated between measured directions
// where needed. The equations are model/conditional.hpp's; decode.cpp evaluates them on a grid.
#include <fmt/format.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "model/conditional.hpp"

namespace btfgmm {
namespace {

// Throws Error(kArgument) for a query off the hemisphere or at a position that is not finite.
void check_queries(std::span<const Query> queries) {
  for (const Query& q : queries) {
    detail::check_direction(q.light, "light");
    detail::check_direction(q.view, "view");
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw Error(Error::Kind::kArgument,
                  fmt::format("pixel position x={} y={} is not finite; give finite x and y "
                              "(any real number: the tile repeats)",
                              q.x, q.y));
  }
}

// The inputs x_I of a query in model units (the tile position wrapped into the tile).
void query_inputs(const BtfModel& model, const Query& q, double x[kInputs]) {
  const auto& u = model.scaling.unit;
  const detail::AngleInputs l = detail::angle_inputs(q.light, u, 2),
                            v = detail::angle_inputs(q.view, u, 4);
  x[0] = detail::tile_coordinate(q.x, model.width);
  x[1] = detail::tile_coordinate(q.y, model.height);
  x[2] = l.alpha;
  x[3] = l.beta;
  x[4] = v.alpha;
  x[5] = v.beta;
}

// One query: Eq. (9)-(10)'s exponents t (scratch of M; the Gaussians of x and y wrap around
// the tile), Eq. (9)'s weights, Eq. (8)'s colour and Eq. (11)'s prediction.
std::array<float, 3> predict_one(const BtfModel& model, const std::vector<double>& base,
                                 const detail::MeanBrdfInterpolator& mean, const Query& q,
                                 std::vector<double>& t) {
  const ProductMixture& mix = model.mixture;
  const auto& u = model.scaling.unit;
  const detail::Periods periods = detail::model_periods(model);
  double x[kInputs];
  query_inputs(model, q, x);
  for (std::size_t m = 0; m < mix.size(); ++m)
    t[m] = detail::log_weight(base[m], mix.mean[m], mix.var[m], x, periods);
  detail::conditional_weights(t);
  detail::ConditionalColour<double> colour;
  for (std::size_t m = 0; m < mix.size(); ++m)
    colour.add(t[m], mix.mean[m][6], mix.mean[m][7], mix.mean[m][8]);
  const std::array<double, 3> e = colour.expectation();
  const auto mb = mean.at(q.light, q.view);
  return {float(detail::predicted_value(e[0], u[6], double(mb[0]))),
          float(detail::predicted_value(e[1], u[7], double(mb[1]))),
          float(detail::predicted_value(e[2], u[8], double(mb[2])))};
}

}  // namespace

void predict(const BtfModel& model, std::span<const Query> queries, std::span<float> rgb) {
  if (rgb.size() < queries.size() * 3)
    throw Error(Error::Kind::kArgument, "predict: the output holds fewer than 3 floats a query");
  check_queries(queries);
  const detail::MeanBrdfInterpolator mean(model);
  const std::vector<double> base = detail::log_weight_bases(model.mixture);
  const std::ptrdiff_t n = std::ptrdiff_t(queries.size());
#pragma omp parallel
  {
    std::vector<double> t(model.mixture.size());
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const auto c = predict_one(model, base, mean, queries[std::size_t(i)], t);
      for (std::size_t k = 0; k < 3; ++k) rgb[std::size_t(i) * 3 + k] = c[k];
    }
  }
}

std::array<float, 3> predict(const BtfModel& model, const Query& query) {
  std::array<float, 3> rgb{};
  predict(model, std::span<const Query>(&query, 1), rgb);
  return rgb;
}

}  // namespace btfgmm
