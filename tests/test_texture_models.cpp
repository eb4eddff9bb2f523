// The probabilistic texture models (3D CAR, 2D CAR, GMRF): parameters re-estimated from data
// synthesised with known ones, synthesis that reproduces a training image's statistics,
// determinism, and seamless tiling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "btfgmm/synth/generate.hpp"
#include "methods/car.hpp"
#include "methods/colour_texture.hpp"
#include "methods/gmrf.hpp"
#include "methods/pyramid.hpp"
#include "methods/relief_structure.hpp"

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

// A synthesis `out` has the training image's mean (within a quarter deviation), covariance
// (within `cov` of the variance) and neighbour correlations (within `corr`).
void expect_statistics_of(const Field& train, const Field& out, double cov, double corr) {
  for (int c = 0; c < 3; ++c) {
    const double sd = std::sqrt(covariance(train, c, c, 0, 0));
    EXPECT_NEAR(mean_of(out, c), mean_of(train, c), 0.25 * sd) << "mean " << c;
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(covariance(out, c, b, 0, 0), covariance(train, c, b, 0, 0), cov * sd * sd)
          << "covariance " << c << b;
    const std::pair<int, int> lags[] = {{1, 0}, {0, 1}, {1, 1}};
    for (auto [dx, dy] : lags) {
      const double rt = covariance(train, c, c, dx, dy) / covariance(train, c, c, 0, 0);
      const double ro = covariance(out, c, c, dx, dy) / covariance(out, c, c, 0, 0);
      EXPECT_NEAR(ro, rt, corr) << "correlation " << c << " at " << dx << "," << dy;
    }
  }
}

// Synthesis from a model estimated on a training image reproduces its mean, covariance (within
// a fifth of the variance) and neighbour correlations (within 0.08). A pyramid of two levels
// does so more loosely (within 0.3 and 0.15; measured: 0.24 and 0.115 at worst): its levels
// are synthesised independently, while the data's are correlated (REDUCE and EXPAND are not
// ideal filters), and this training image is one CAR field, the one-level model's own class.
class Reproduces : public ::testing::TestWithParam<TextureKind> {};

TEST_P(Reproduces, TheTrainingImagesStatistics) {
  const Field train = training_image(GetParam(), 96, 9);
  for (int levels : {1, 2}) {
    SCOPED_TRACE(levels);
    const auto model = fit_colour_texture(GetParam(), train, kMaxCausalOrder, levels);
    EXPECT_EQ(model->levels(), levels);
    expect_statistics_of(train, model->synthesise(128, 128, 10), levels == 1 ? 0.2 : 0.3,
                         levels == 1 ? 0.08 : 0.15);
  }
}

TEST_P(Reproduces, TheSameImageFromTheSameSeed) {
  const Field train = training_image(GetParam(), 48, 9);
  const auto model = fit_colour_texture(GetParam(), train, 2, 2);
  EXPECT_EQ(model->synthesise(40, 24, 3).values, model->synthesise(40, 24, 3).values);
  EXPECT_NE(model->synthesise(40, 24, 3).values, model->synthesise(40, 24, 4).values);
}

// The mean squared difference of neighbours across the torus's seams (x = W-1 to 0, y = H-1
// to 0) against inside: a seam shows as a larger jump. One level and a pyramid of three.
TEST_P(Reproduces, ATextureThatTilesWithoutSeams) {
  const Field train = training_image(GetParam(), 64, 11);
  for (int levels : {1, 3}) {
    SCOPED_TRACE(levels);
    const Field f = fit_colour_texture(GetParam(), train, 2, levels)->synthesise(128, 128, 12);
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
}

INSTANTIATE_TEST_SUITE_P(Kinds, Reproduces,
                         ::testing::Values(TextureKind::kCar3d, TextureKind::kCar2d,
                                           TextureKind::kGmrf));

// The pyramid collapses exactly into the image it was made of, at a size that halves evenly
// and at one that does not; its levels halve (rounded up); a constant image has Laplacian
// levels of 0 and the constant at the coarsest.
TEST(Pyramid, CollapsesExactlyIntoItsImage) {
  for (const auto& [w, h] : {std::pair{32, 16}, std::pair{21, 13}}) {
    const Field f = synthesise_car(known_car3d(), w, h, 3);
    const std::vector<Field> levels = laplacian_pyramid(f, 3);
    ASSERT_EQ(levels.size(), 3u);
    EXPECT_EQ(levels[1].width, level_side(w, 1));
    EXPECT_EQ(levels[2].height, level_side(h, 2));
    const Field back = collapse(levels);
    ASSERT_EQ(back.values.size(), f.values.size());
    for (std::size_t i = 0; i < f.values.size(); ++i)
      EXPECT_NEAR(back.values[i], f.values[i], 1e-9);
  }
  EXPECT_EQ(level_side(21, 2), 6);
  EXPECT_EQ(max_levels(32, 32, 8), 3);
  EXPECT_EQ(max_levels(16, 40, 8), 2);
  EXPECT_EQ(max_levels(12, 12, 8), 1);
  Field flat(16, 16, 1);
  for (double& v : flat.values) v = 7.0;
  const std::vector<Field> levels = laplacian_pyramid(flat, 3);
  for (double v : levels[0].values) EXPECT_NEAR(v, 0.0, 1e-12);
  for (double v : levels[2].values) EXPECT_NEAR(v, 7.0, 1e-12);
}

// An image of a generated material, under a light 30 degrees from the top, seen from the top.
Field material_image(const char* material, int size) {
  GenerateConfig g;
  g.material = material;
  g.size = size;
  g.seed = 5;
  g.supersample = 1;
  g.lights = DirectionSet({Direction{30, 0}});
  g.views = DirectionSet({Direction{0, 0}});
  const Btf btf = generate(g);
  Field f(size, size, 3);
  f.values.assign(btf.data().begin(), btf.data().end());
  return f;
}

// The variance of the luminance on each level of its Laplacian pyramid of 3 levels: the
// image's energy at each scale.
std::vector<double> scale_variances(const Field& f) {
  Field lum(f.width, f.height, 1);
  for (std::size_t i = 0; i < f.pixels(); ++i)
    lum.values[i] = (f.values[i * 3] + f.values[i * 3 + 1] + f.values[i * 3 + 2]) / 3;
  std::vector<double> out;
  for (const Field& l : laplacian_pyramid(lum, 3)) out.push_back(covariance(l, 0, 0, 0, 0));
  return out;
}

// The mean over the scales of |ln(variance of the synthesis / the data's)|, the synthesis's
// variances averaged over 3 seeds.
double scale_error(const Field& data, const ColourTexture& model) {
  const std::vector<double> d = scale_variances(data);
  std::vector<double> s(d.size(), 0.0);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const std::vector<double> v = scale_variances(model.synthesise(data.width, data.height, seed));
    for (std::size_t k = 0; k < s.size(); ++k) s[k] += v[k] / 3;
  }
  double e = 0;
  for (std::size_t k = 0; k < s.size(); ++k)
    e += std::abs(std::log(s[k] / d[k])) / double(s.size());
  return e;
}

// What the pyramid is for: structure larger than a neighbourhood of radius 3. On generated
// corduroy (ridges) and knit (loops), 32 x 32, each model of two levels reproduces the image's
// energy at each of three scales (the variances of its Laplacian levels) better than the
// model of one level, and over the six, by 15% at least. Measured (the error above, one
// level -> two): corduroy 3D CAR 0.72 -> 0.45, 2D CAR 0.86 -> 0.64, GMRF 0.83 -> 0.75; knit
// 0.48 -> 0.38, 0.45 -> 0.39, 0.46 -> 0.39; mean 0.63 -> 0.50 (21% less).
TEST(Pyramid, TwoLevelsReproduceTheEnergyAtEachScaleBetter) {
  double one_sum = 0, two_sum = 0;
  for (const char* material : {"corduroy", "knit"}) {
    const Field data = material_image(material, 32);
    for (TextureKind kind : {TextureKind::kCar3d, TextureKind::kCar2d, TextureKind::kGmrf}) {
      const double one = scale_error(data, *fit_colour_texture(kind, data, kMaxCausalOrder, 1));
      const double two = scale_error(data, *fit_colour_texture(kind, data, kMaxCausalOrder, 2));
      EXPECT_LT(two, one) << material << " " << int(kind);
      one_sum += one, two_sum += two;
    }
  }
  EXPECT_LT(two_sum, 0.85 * one_sum) << one_sum / 6 << " -> " << two_sum / 6;
}

// The relief structure's known answer: an image made, pixel by pixel, from a range map's
// shape (height, squared slopes and their product, curvature) and its slope along the light,
// all written out here on the torus, with known gains, gives those gains back; taking the
// shape and the slope away leaves nothing; at twice the size the structure repeats the tile's,
// and under the light from the opposite azimuth the slope changes sign.
TEST(ReliefStructure, KnownGainsAreRecoveredAndTheStructureTiles) {
  const int w = 12, h = 10;
  std::vector<float> heights(std::size_t(w * h));
  const double pi = std::acos(-1.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      heights[std::size_t(y * w + x)] =
          float(std::sin(2 * pi * x / w) + 0.6 * std::cos(4 * pi * y / h) +
                0.3 * std::sin(2 * pi * (x + 2 * y) / w));
  const auto z = [&](int x, int y) {
    return double(heights[std::size_t(((y + h) % h) * w + (x + w) % w)]);
  };
  const Vec3 light{0.5, -0.3, std::sqrt(1 - 0.34)};
  const double gains[3][kReliefFeatures] = {
      {120, 8, 3, -2, 1.5, 4, 20}, {90, -5, -1, 2, 0.5, -3, 12}, {60, 2, 6, 1, -2, 7, -9}};
  std::vector<double> rgb(std::size_t(w * h) * 3), slope_only(rgb.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double hx = (z(x + 1, y) - z(x - 1, y)) / 2, hy = (z(x, y + 1) - z(x, y - 1)) / 2;
      const double f[kReliefFeatures] = {
          1,
          z(x, y),
          hx * hx,
          hy * hy,
          hx * hy,
          z(x + 1, y) + z(x - 1, y) + z(x, y + 1) + z(x, y - 1) - 4 * z(x, y),
          -(hx * light.x + hy * light.y)};
      for (int c = 0; c < 3; ++c) {
        double v = 0;
        for (int j = 0; j < kReliefFeatures; ++j) v += gains[c][j] * f[j];
        rgb[std::size_t(y * w + x) * 3 + std::size_t(c)] = v;
        slope_only[std::size_t(y * w + x) * 3 + std::size_t(c)] = gains[c][6] * f[6];
      }
    }
  const ReliefFeatures features = relief_features(heights, w, h);
  const ReliefStructure s = fit_relief_structure(features, light, rgb.data());
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < kReliefFeatures; ++j)
      EXPECT_NEAR(s.gain[std::size_t(c * kReliefFeatures + j)], gains[c][j],
                  1e-4 * (1 + std::abs(gains[c][j])))
          << c << " " << j;
  std::vector<double> rest = rgb;
  add_relief_shape(s, features, rest.data(), w, h, -1.0);
  add_relief_slope(s, features, light, rest.data(), w, h, -1.0);
  for (double v : rest) EXPECT_NEAR(v, 0.0, 1e-3);
  std::vector<double> twice(std::size_t(4 * w * h) * 3, 0.0);
  add_relief_shape(s, features, twice.data(), 2 * w, 2 * h);
  add_relief_slope(s, features, light, twice.data(), 2 * w, 2 * h);
  for (int y = 0; y < 2 * h; ++y)
    for (int x = 0; x < 2 * w; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(twice[std::size_t(y * 2 * w + x) * 3 + std::size_t(c)],
                    rgb[std::size_t((y % h) * w + x % w) * 3 + std::size_t(c)], 1e-3);
  std::vector<double> opposite(rgb.size(), 0.0);
  add_relief_slope(s, features, Vec3{-light.x, -light.y, light.z}, opposite.data(), w, h);
  for (std::size_t i = 0; i < opposite.size(); ++i) EXPECT_NEAR(opposite[i], -slope_only[i], 1e-3);
}

}  // namespace
}  // namespace btfgmm::detail
