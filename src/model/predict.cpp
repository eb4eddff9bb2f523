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

// One query: Eq. (9)-(10)'s exponents t (scratch of M; the Gaussians of x and y wrap around
// the tile), Eq. (9)'s weights, Eq. (8)'s colour and Eq. (11)'s prediction.
std::array<float, 3> predict_one(const BtfModel& model, const std::vector<double>& base,
                                 const detail::MeanBrdfInterpolator& mean, const Query& q,
                                 std::vector<double>& t) {
  const ProductMixture& mix = model.mixture;
  const auto& u = model.scaling.unit;
  const detail::Periods periods = detail::model_periods(model);
  double x[kInputs];
  detail::query_inputs(model, q, x);
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
  detail::check_queries(queries);
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
