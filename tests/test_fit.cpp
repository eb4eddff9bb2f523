// End to end: generate a BTF, fit the model, decode, measure.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"

namespace btfgmm {
namespace {

double rmse(const Btf& a, const Btf& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.data().size(); ++i) {
    const double d = double(a.data()[i]) - double(b.data()[i]);
    s += d * d;
  }
  return std::sqrt(s / double(a.data().size()));
}

// The mean BRDF alone as a model: every pixel of an image equals its mean.
Btf mean_brdf_only(const Btf& btf) {
  const std::vector<float> mean = mean_brdf(btf);
  Btf out(btf.lights(), btf.views(), btf.width(), btf.height(), btf.format());
  for (std::size_t i = 0; i < btf.image_count(); ++i)
    for (std::size_t p = 0; p < std::size_t(btf.width()) * btf.height(); ++p)
      for (int c = 0; c < 3; ++c) out.data()[i * btf.image_floats() + p * 3 + c] = mean[i * 3 + c];
  return out;
}

TEST(Fit, ModelBeatsTheMeanBrdfOnAGeneratedTile) {
  GenerateConfig g;
  g.material = "corduroy";
  g.size = 16;
  g.seed = 1;
  const Btf btf = generate(g);
  FitConfig c;
  c.components = 100;
  c.seed = 7;
  c.em.max_iterations = 8;
  const BtfModel model = fit_model(btf, c);
  const Btf decoded = decode(model, btf.lights(), btf.views(), btf.width(), btf.height());
  const double model_rmse = rmse(decoded, btf);
  const double mean_rmse = rmse(mean_brdf_only(btf), btf);
  std::printf(
      "16x16 corduroy, 81x81 directions, M = 100, 8 iterations: RMSE model %.3f, mean "
      "BRDF alone %.3f (levels)\n",
      model_rmse, mean_rmse);
  // The margin asserted: the mixture removes at least 15 % of the mean BRDF's error.
  EXPECT_LT(model_rmse, 0.85 * mean_rmse);
  // f16 parameters change the decoded values by little.
  BtfModel half = deserialize_model(serialize_model([&] {
                                      BtfModel h = model;
                                      h.precision = Precision::kF16;
                                      return h;
                                    }()),
                                    "f16");
  const double f16_rmse = rmse(decode(half, btf.lights(), btf.views(), 16, 16), btf);
  std::printf("  with f16 parameters: RMSE %.3f\n", f16_rmse);
  EXPECT_LT(std::abs(f16_rmse - model_rmse), 0.05 * model_rmse);

  // Decoding skips components within its tolerance: against every component evaluated
  // (tolerance 0), the default (1e-3 levels) stays within 2e-3 levels, a coarse 2 levels
  // within 2.001, 256 levels within 256.001 but not exactly equal; and the exact decode equals
  // predict() to 1e-3.
  const Btf exact = decode(model, btf.lights(), btf.views(), 16, 16, 0.0);
  auto max_diff = [&](const Btf& other) {
    double worst = 0.0;
    for (std::size_t i = 0; i < exact.data().size(); ++i)
      worst = std::max(worst, std::abs(double(exact.data()[i]) - double(other.data()[i])));
    return worst;
  };
  EXPECT_LE(max_diff(decoded), 2e-3);
  const double coarse = max_diff(decode(model, btf.lights(), btf.views(), 16, 16, 2.0));
  std::printf("  decode: largest change with tolerance 1e-3: %.2e, with 2 levels: %.3f\n",
              max_diff(decoded), coarse);
  EXPECT_LE(coarse, 2.001);
  // Whether 2 levels skip a term large enough to change a float sum depends on the model's
  // last bits (the AVX-512 and the portable EM give models a rounding apart): a tolerance of
  // 256 levels must skip, and stay within its bound.
  const double wide = max_diff(decode(model, btf.lights(), btf.views(), 16, 16, 256.0));
  std::printf("  with 256 levels: %.3f\n", wide);
  EXPECT_LE(wide, 256.001);
  EXPECT_GT(wide, 0.0);
  std::vector<Query> queries;
  for (std::size_t l = 0; l < btf.lights().size(); l += 7)
    for (std::size_t v = 0; v < btf.views().size(); v += 5)
      queries.push_back({double(l % 16), double(v % 16), btf.lights()[l], btf.views()[v]});
  std::vector<float> rgb(queries.size() * 3);
  predict(model, queries, rgb);
  std::size_t i = 0;
  for (std::size_t l = 0; l < btf.lights().size(); l += 7)
    for (std::size_t v = 0; v < btf.views().size(); v += 5, ++i)
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(exact.at(l, v, int(l % 16), int(v % 16), ch), rgb[i * 3 + std::size_t(ch)],
                    1e-3);
  EXPECT_THROW(decode(model, btf.lights(), btf.views(), 4, 4, -1.0), Error);
  EXPECT_THROW(decode(model, btf.lights(), btf.views(), 4, 4, NAN), Error);
}

}  // namespace
}  // namespace btfgmm
