// The probabilistic texture models (3D CAR, 2D CAR, GMRF): parameters re-estimated from data
// synthesised with known ones, synthesis that reproduces a training image's statistics,
// determinism, and seamless tiling.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "methods/car.hpp"
#include "methods/colour_texture.hpp"
#include "methods/gmrf.hpp"

namespace btfgmm::detail {
namespace {

// A stable 3D CAR on the order-2 neighbourhood (left, above, upper left, upper right).
CarModel known_car3d() {
  CarModel m;
  m.d = 3;
  m.neighbourhood = causal_neighbourhood(2);
  m.mean = {100, 80, 60};
  const double diag[4] = {0.4, 0.3, -0.1, 0.1};
  m.gamma.assign(3 * 12, 0.0);
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) {
      m.gamma[std::size_t(c * 12 + k * 3 + c)] = diag[k];
      m.gamma[std::size_t(c * 12 + k * 3 + (c + 1) % 3)] = 0.05;  // colour cross-talk
    }
  m.sigma = {4.0, 1.2, 0.4, 1.2, 4.0, 0.8, 0.4, 0.8, 4.0};
  return m;
}

CarModel known_car2d() {
  CarModel m;
  m.d = 1;
  m.neighbourhood = causal_neighbourhood(2);
  m.mean = {20};
  m.gamma = {0.5, 0.3, -0.15, 0.1};
  m.sigma = {9.0};
  return m;
}

GmrfModel known_gmrf() {
  GmrfModel m;
  m.half = symmetric_half(2);
  m.a = {0.2, 0.15, 0.05, -0.03};
  m.sigma2 = 4.0;
  m.mean = 50;
  return m;
}

// The sample covariance of channels a and b of f at lag (dx, dy), on the torus.
double covariance(const Field& f, int a, int b, int dx, int dy) {
  double ma = 0, mb = 0, s = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i)
    ma += f.values[i * std::size_t(f.channels) + std::size_t(a)],
        mb += f.values[i * std::size_t(f.channels) + std::size_t(b)];
  ma /= double(f.pixels());
  mb /= double(f.pixels());
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      s += (f.at(x, y, a) - ma) * (f.wrapped(x + dx, y + dy, b) - mb);
  return s / double(f.pixels());
}

double mean_of(const Field& f, int c) {
  double m = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i)
    m += f.values[i * std::size_t(f.channels) + std::size_t(c)];
  return m / double(f.pixels());
}

TEST(Car, ThreeDimensionalParametersAreReEstimated) {
  const CarModel truth = known_car3d();
  const Field y = synthesise_car(truth, 128, 128, 5);
  const CarModel m = estimate_car(y, truth.neighbourhood);
  for (std::size_t i = 0; i < truth.gamma.size(); ++i)
    EXPECT_NEAR(m.gamma[i], truth.gamma[i], 0.03) << "gamma " << i;
  for (std::size_t i = 0; i < 9; ++i)
    EXPECT_NEAR(m.sigma[i], truth.sigma[i], 0.25) << "sigma " << i;
  for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(m.mean[c], truth.mean[c], 0.5);
}

TEST(Car, OneDimensionalParametersAreReEstimated) {
  const CarModel truth = known_car2d();
  const Field y = synthesise_car(truth, 128, 128, 6);
  const CarModel m = estimate_car(y, truth.neighbourhood);
  for (std::size_t i = 0; i < truth.gamma.size(); ++i)
    EXPECT_NEAR(m.gamma[i], truth.gamma[i], 0.03) << "gamma " << i;
  EXPECT_NEAR(m.sigma[0], 9.0, 0.45);  // 5%
}

TEST(Car, TheDecisionRuleChoosesTheTrueNeighbourhood) {
  const Field y = synthesise_car(known_car2d(), 128, 128, 7);
  EXPECT_EQ(select_car(y).neighbourhood, causal_neighbourhood(2));
}

TEST(Gmrf, ParametersAreReEstimated) {
  const GmrfModel truth = known_gmrf();
  const Field y = synthesise_gmrf(truth, 128, 128, 8);
  const GmrfModel m = estimate_gmrf(y, truth.half);
  for (std::size_t i = 0; i < truth.a.size(); ++i) EXPECT_NEAR(m.a[i], truth.a[i], 0.02) << i;
  EXPECT_NEAR(m.sigma2, 4.0, 0.2);  // 5%
  EXPECT_NEAR(m.mean, 50.0, 0.5);
  EXPECT_EQ(m.shrink, 1.0);
}

TEST(Gmrf, AnEstimateThatIsNotPositiveDefiniteIsShrunk) {
  // A ramp in x: neighbours predict a pixel perfectly, a_(1,0) = 1/2, mu(0) = 0.
  Field ramp(32, 32, 1);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) ramp.at(x, y) = x + 0.01 * std::sin(x * y);
  const GmrfModel m = estimate_gmrf(ramp, symmetric_half(1));
  EXPECT_LT(m.shrink, 1.0);
  EXPECT_GE(gmrf_spectrum(m, 0, 0), kMinSpectrum - 1e-9);
}

// An RGB training image of the kind's own class: a 3D CAR field for the CAR models; for the
// GMRF three bands of known GMRFs mixed by a colour matrix.
Field training_image(TextureKind kind, int size, std::uint64_t seed) {
  if (kind != TextureKind::kGmrf) return synthesise_car(known_car3d(), size, size, seed);
  GmrfModel second = known_gmrf(), third = known_gmrf();
  second.a = {0.3, 0.1, 0.0, 0.05};
  third.a = {0.1, 0.1, 0.1, 0.1};
  const Field b[3] = {synthesise_gmrf(known_gmrf(), size, size, seed),
                      synthesise_gmrf(second, size, size, seed + 1),
                      synthesise_gmrf(third, size, size, seed + 2)};
  const double mix[3][3] = {{1.0, 0.5, 0.0}, {0.5, 1.0, 0.2}, {0.3, 0.0, 1.0}};
  Field rgb(size, size, 3);
  for (std::size_t i = 0; i < rgb.pixels(); ++i)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) rgb.values[i * 3 + std::size_t(c)] += mix[c][k] * b[k].values[i];
  return rgb;
}

// Synthesis from a model estimated on a training image reproduces its mean, covariance and
// neighbour correlations.
class Reproduces : public ::testing::TestWithParam<TextureKind> {};

TEST_P(Reproduces, TheTrainingImagesStatistics) {
  const Field train = training_image(GetParam(), 96, 9);
  const auto model = fit_colour_texture(GetParam(), train, kMaxCausalOrder);
  const Field out = model->synthesise(128, 128, 10);
  for (int c = 0; c < 3; ++c) {
    const double sd = std::sqrt(covariance(train, c, c, 0, 0));
    EXPECT_NEAR(mean_of(out, c), mean_of(train, c), 0.25 * sd) << "mean " << c;
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(covariance(out, c, b, 0, 0), covariance(train, c, b, 0, 0), 0.2 * sd * sd)
          << "covariance " << c << b;
    const std::pair<int, int> lags[] = {{1, 0}, {0, 1}, {1, 1}};
    for (auto [dx, dy] : lags) {
      const double rt = covariance(train, c, c, dx, dy) / covariance(train, c, c, 0, 0);
      const double ro = covariance(out, c, c, dx, dy) / covariance(out, c, c, 0, 0);
      EXPECT_NEAR(ro, rt, 0.08) << "correlation " << c << " at " << dx << "," << dy;
    }
  }
}

TEST_P(Reproduces, TheSameImageFromTheSameSeed) {
  const Field train = training_image(GetParam(), 48, 9);
  const auto model = fit_colour_texture(GetParam(), train, 2);
  EXPECT_EQ(model->synthesise(40, 24, 3).values, model->synthesise(40, 24, 3).values);
  EXPECT_NE(model->synthesise(40, 24, 3).values, model->synthesise(40, 24, 4).values);
}

// The mean squared difference of neighbours across the torus's seams (x = W-1 to 0, y = H-1
// to 0) against inside: a seam shows as a larger jump.
TEST_P(Reproduces, ATextureThatTilesWithoutSeams) {
  const Field train = training_image(GetParam(), 64, 11);
  const Field f = fit_colour_texture(GetParam(), train, 2)->synthesise(128, 128, 12);
  double seam = 0, inside = 0;
  std::size_t ns = 0, ni = 0;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x)
      for (int c = 0; c < 3; ++c) {
        const double h = f.wrapped(x + 1, y, c) - f.at(x, y, c);
        const double v = f.wrapped(x, y + 1, c) - f.at(x, y, c);
        (x == 127 ? seam : inside) += h * h, ++(x == 127 ? ns : ni);
        (y == 127 ? seam : inside) += v * v, ++(y == 127 ? ns : ni);
      }
  const double ratio = (seam / double(ns)) / (inside / double(ni));
  EXPECT_GT(ratio, 0.75);
  EXPECT_LT(ratio, 1.33);
}

INSTANTIATE_TEST_SUITE_P(Kinds, Reproduces,
                         ::testing::Values(TextureKind::kCar3d, TextureKind::kCar2d,
                                           TextureKind::kGmrf));

}  // namespace
}  // namespace btfgmm::detail
