// The range map: photometric-stereo normals on an analytic surface, Frankot-Chellappa heights,
// and the range maps of generated materials against the heights the generator renders.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/range_map.hpp"
#include "btfgmm/synth/generate.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

// h(x, y) = 0.8 sin(2 pi x / 32) + 0.6 cos(4 pi y / 32), sampled at pixel centres, and its
// unit normals (-hx, -hy, 1) / |.|: slopes up to 25 degrees.
struct Sinusoid {
  static constexpr int kSize = 32;
  double h(double x, double y) const {
    return 0.8 * std::sin(2 * kPi * x / kSize) + 0.6 * std::cos(4 * kPi * y / kSize);
  }
  Vec3 normal(double x, double y) const {
    const double hx = 0.8 * 2 * kPi / kSize * std::cos(2 * kPi * x / kSize);
    const double hy = -0.6 * 4 * kPi / kSize * std::sin(4 * kPi * y / kSize);
    const double n = std::sqrt(hx * hx + hy * hy + 1);
    return {-hx / n, -hy / n, 1 / n};
  }
};

// The surface rendered Lambertian (albedo 0.7, linear HDR values) from the top view under the
// UBO lights.
Btf lambertian(const Sinusoid& s) {
  Btf btf(DirectionSet::ubo81(), DirectionSet::rings({{0.0, 1}}), Sinusoid::kSize, Sinusoid::kSize,
          SampleFormat::kHdr);
  for (std::size_t l = 0; l < btf.lights().size(); ++l) {
    const Vec3 d = to_vector(btf.lights()[l]);
    for (int y = 0; y < btf.height(); ++y)
      for (int x = 0; x < btf.width(); ++x) {
        const Vec3 n = s.normal(x, y);
        const double v = 0.7 * std::max(0.0, n.x * d.x + n.y * d.y + n.z * d.z);
        for (int c = 0; c < 3; ++c) btf.at(l, 0, x, y, c) = float(v);
      }
  }
  return btf;
}

// The residual of a square image (n x n, row-major) after its least-squares plane
// a0 + a1 x + a2 y: on a centred grid x, y and 1 are orthogonal, so each is a projection.
std::vector<double> without_plane(const std::vector<float>& a) {
  const int n = int(std::lround(std::sqrt(double(a.size()))));
  double m = 0, sx = 0, sy = 0, xx = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double v = a[std::size_t(y * n + x)], cx = x - (n - 1) / 2.0, cy = y - (n - 1) / 2.0;
      m += v, sx += v * cx, sy += v * cy, xx += cx * cx;
    }
  std::vector<double> out(a.size());
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double cx = x - (n - 1) / 2.0, cy = y - (n - 1) / 2.0;
      out[std::size_t(y * n + x)] =
          a[std::size_t(y * n + x)] - m / double(a.size()) - sx / xx * cx - sy / xx * cy;
    }
  return out;
}

// Pearson's correlation of a and b after removing the mean plane of each.
double plane_free_correlation(const std::vector<float>& a, const std::vector<float>& b) {
  const std::vector<double> ra = without_plane(a), rb = without_plane(b);
  double ab = 0, aa = 0, bb = 0;
  for (std::size_t i = 0; i < ra.size(); ++i)
    ab += ra[i] * rb[i], aa += ra[i] * ra[i], bb += rb[i] * rb[i];
  return ab / std::sqrt(aa * bb);
}

TEST(RangeMap, PhotometricNormalsOfALambertianSinusoidWithinATenthOfADegree) {
  const Sinusoid s;
  const Btf btf = lambertian(s);
  const std::vector<float> n = photometric_normals(btf, 0);
  double worst = 0;
  for (int y = 0; y < btf.height(); ++y)
    for (int x = 0; x < btf.width(); ++x) {
      const Vec3 t = s.normal(x, y);
      const float* e = &n[(std::size_t(y) * 32 + std::size_t(x)) * 3];
      const double dot = t.x * e[0] + t.y * e[1] + t.z * e[2];
      worst = std::max(worst, std::acos(std::min(1.0, dot)) * 180 / kPi);
    }
  EXPECT_LT(worst, 0.1);
}

TEST(RangeMap, FrankotChellappaRecoversTheSinusoidsHeights) {
  const Sinusoid s;
  const RangeMap map = estimate_range_map(lambertian(s));
  ASSERT_EQ(map.heights.size(), 32u * 32u);
  double worst = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      worst =
          std::max(worst, std::abs(map.heights[std::size_t(y) * 32 + std::size_t(x)] - s.h(x, y)));
  EXPECT_LT(worst, 0.01);  // of a relief 2.8 pixels deep
}

TEST(RangeMap, TooFewLightsAreAnError) {
  Btf btf(DirectionSet::rings({{75.0, 6}}), DirectionSet::rings({{0.0, 1}}), 4, 4,
          SampleFormat::kHdr);
  try {
    estimate_range_map(btf);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at least 3 lights"), std::string::npos) << e.what();
  }
}

class GeneratedRangeMap : public ::testing::TestWithParam<const char*> {};

// The generator renders shadows, masking, gloss and an sRGB encoding, which photometric
// stereo does not model: the range map still follows the true relief, at 0.9 or better
// (measured: corduroy 0.977, knit 0.919, bumps 0.999), and tiles: the heights' jumps across
// the seams are those inside.
TEST_P(GeneratedRangeMap, CorrelatesWithTheTrueHeightsAndTiles) {
  GenerateConfig g;
  g.material = GetParam();
  g.size = 32;
  g.seed = 3;
  g.views = DirectionSet::rings({{0.0, 1}});
  const RangeMap map = estimate_range_map(generate(g));
  const double r = plane_free_correlation(map.heights, generate_heights(g));
  EXPECT_GE(r, 0.9) << g.material;
  double seam = 0, inside = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const auto h = [&](int i, int j) { return map.heights[std::size_t((j % 32) * 32 + i % 32)]; };
      const double d = std::pow(h(x + 1, y) - h(x, y), 2) + std::pow(h(x, y + 1) - h(x, y), 2);
      (x == 31 || y == 31 ? seam : inside) += d;
    }
  EXPECT_LT(seam / 63.0, 2.0 * inside / (32.0 * 32.0 - 63.0)) << g.material;
}

INSTANTIATE_TEST_SUITE_P(Materials, GeneratedRangeMap,
                         ::testing::Values("corduroy", "knit", "bumps"));

// Leather's gloss is the hardest for a Lambertian photometric stereo: 0.870.
TEST(RangeMap, GlossyLeatherStillCorrelatesAt085) {
  GenerateConfig g;
  g.material = "leather";
  g.size = 32;
  g.seed = 3;
  g.views = DirectionSet::rings({{0.0, 1}});
  const RangeMap map = estimate_range_map(generate(g));
  EXPECT_GE(plane_free_correlation(map.heights, generate_heights(g)), 0.85);
}

}  // namespace
}  // namespace btfgmm
