// The synthetic BTF generator: determinism, validation, and the effects a measured BTF shows
// (self-shadowing, parallax, highlights, seamless tiling).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/synth/generate.hpp"

namespace btfgmm {
namespace {

// A small direction set for fast tests: 19 directions on four rings.
DirectionSet small_set() {
  return DirectionSet::rings({{0, 1}, {30, 4}, {60, 6}, {75, 8}});
}
// A smaller one: 9 directions, frontal first.
DirectionSet tiny_set() {
  return DirectionSet::rings({{0, 1}, {45, 4}, {75, 4}});
}

double mean(const Btf& b, std::size_t l, std::size_t v) {
  const float* img = b.image(l, v);
  double s = 0.0;
  for (std::size_t i = 0; i < b.image_floats(); ++i) s += img[i];
  return s / double(b.image_floats());
}

double stddev(const Btf& b, std::size_t l, std::size_t v) {
  const float* img = b.image(l, v);
  const double m = mean(b, l, v);
  double s = 0.0;
  for (std::size_t i = 0; i < b.image_floats(); ++i) s += (img[i] - m) * (img[i] - m);
  return std::sqrt(s / double(b.image_floats()));
}

// Mean absolute difference between columns a and b of an image, over rows and channels.
double column_difference(const Btf& btf, std::size_t l, std::size_t v, int a, int b) {
  double s = 0.0;
  for (int y = 0; y < btf.height(); ++y)
    for (int c = 0; c < 3; ++c) s += std::abs(btf.at(l, v, a, y, c) - btf.at(l, v, b, y, c));
  return s / (3.0 * btf.height());
}

double row_difference(const Btf& btf, std::size_t l, std::size_t v, int a, int b) {
  double s = 0.0;
  for (int x = 0; x < btf.width(); ++x)
    for (int c = 0; c < 3; ++c) s += std::abs(btf.at(l, v, x, a, c) - btf.at(l, v, x, b, c));
  return s / (3.0 * btf.width());
}

bool same_bytes(const Btf& a, const Btf& b) {
  return a.data().size() == b.data().size() &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

GenerateConfig small(const std::string& material, int size = 24) {
  GenerateConfig c;
  c.material = material;
  c.size = size;
  c.lights = small_set();
  c.views = small_set();
  return c;
}

TEST(Generate, KnowsItsMaterials) {
  const auto names = material_names();
  for (const char* want : {"corduroy", "knit", "bumps"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
}

TEST(Generate, SameSeedSameBytesDifferentSeedDifferentImages) {
  for (const auto& material : material_names()) {
    GenerateConfig c = small(material, 16);
    c.lights = tiny_set();
    c.views = tiny_set();
    c.seed = 7;
    const Btf a = generate(c), b = generate(c);
    EXPECT_TRUE(same_bytes(a, b)) << material;
    c.seed = 8;
    const Btf d = generate(c);
    EXPECT_FALSE(same_bytes(a, d)) << material;
    // Not merely a few pixels: the seed moves the pattern and its noise.
    double diff = 0.0;
    for (std::size_t i = 0; i < a.data().size(); ++i) diff += std::abs(a.data()[i] - d.data()[i]);
    EXPECT_GT(diff / double(a.data().size()), 3.0) << material;
  }
}

TEST(Generate, SameBytesWhateverTheThreadCount) {
  GenerateConfig c = small("bumps", 16);
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const Btf one = generate(c);
  omp_set_num_threads(3);
  const Btf three = generate(c);
  omp_set_num_threads(before);
  EXPECT_TRUE(same_bytes(one, three));
}

TEST(Generate, FormatSizeAndOrigin) {
  GenerateConfig c = small("knit", 20);
  const Btf b = generate(c);
  EXPECT_EQ(b.width(), 20);
  EXPECT_EQ(b.height(), 20);
  EXPECT_EQ(b.format(), SampleFormat::kLdr8);
  EXPECT_EQ(b.lights(), c.lights);
  EXPECT_EQ(b.views(), c.views);
  EXPECT_EQ(b.origin().x, 0);
  EXPECT_EQ(b.origin().y, 0);
  EXPECT_EQ(b.origin().width, 20);
  EXPECT_EQ(b.origin().height, 20);
  c.hdr = true;
  EXPECT_EQ(generate(c).format(), SampleFormat::kHdr);
}

TEST(Generate, EveryMaterialGivesLevelsOrFiniteValuesAndTexture) {
  for (const auto& material : material_names()) {
    GenerateConfig c = small(material, 24);
    c.lights = tiny_set();
    c.views = tiny_set();
    const Btf ldr = generate(c);
    for (float v : ldr.data()) {
      ASSERT_GE(v, 0.0f) << material;
      ASSERT_LE(v, 255.0f) << material;
      ASSERT_EQ(v, std::round(v)) << material;
    }
    // Frontal light and view (index 0 in both sets): textured, mid-bright.
    EXPECT_GT(stddev(ldr, 0, 0), 5.0) << material;
    EXPECT_GT(mean(ldr, 0, 0), 40.0) << material;
    EXPECT_LT(mean(ldr, 0, 0), 220.0) << material;

    c.hdr = true;
    const Btf hdr = generate(c);
    bool any_fraction = false;
    for (float v : hdr.data()) {
      ASSERT_TRUE(std::isfinite(v)) << material;
      ASSERT_GE(v, 0.0f) << material;
      if (v != std::round(v)) any_fraction = true;
    }
    EXPECT_TRUE(any_fraction) << material;  // linear floats, not levels
    EXPECT_GT(stddev(hdr, 0, 0), 0.01) << material;
  }
}

TEST(Generate, LdrIsTheSrgbEncodingOfHdr) {
  // The 8-bit levels are the sRGB encoding of the linear values, rounded to the nearest level.
  GenerateConfig c = small("leather", 16);
  const Btf ldr = generate(c);
  c.hdr = true;
  const Btf hdr = generate(c);
  ASSERT_EQ(ldr.data().size(), hdr.data().size());
  int clipped = 0;
  for (std::size_t i = 0; i < hdr.data().size(); ++i) {
    const double x = hdr.data()[i];
    const double e = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    const double want = std::clamp(255.0 * e, 0.0, 255.0);
    ASSERT_NEAR(ldr.data()[i], want, 0.5 + 1e-3) << i << " linear " << x;
    clipped += x >= 1.0;
  }
  // Highlights may clip, but only a little.
  EXPECT_LT(clipped, int(hdr.data().size() / 20));
}

TEST(Generate, DirectionsAtTheHorizonGiveFiniteImages) {
  for (const auto& material : material_names()) {
    GenerateConfig c = small(material, 8);
    c.hdr = true;
    c.lights = DirectionSet({{90, 0}, {89.5, 120}, {0, 0}});
    c.views = DirectionSet({{90, 45}, {0, 0}});
    const Btf b = generate(c);
    for (float v : b.data()) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f) << material;
  }
}

TEST(Generate, GrazingLightAcrossTheWalesCastsShadows) {
  // Light at theta 75 from +x (azimuth 0) crosses the corduroy wales (they run along y).
  GenerateConfig c = small("corduroy", 32);
  c.lights = DirectionSet({{0, 0}, {75, 0}, {75, 180}});
  c.views = DirectionSet({{0, 0}});
  const Btf b = generate(c);
  const double frontal = mean(b, 0, 0);
  EXPECT_LT(mean(b, 1, 0), 0.6 * frontal);
  EXPECT_LT(mean(b, 2, 0), 0.6 * frontal);
  // The shadows fall on opposite sides of the wales: the two grazing images differ.
  double diff = 0.0;
  for (std::size_t i = 0; i < b.image_floats(); ++i)
    diff += std::abs(b.image(1, 0)[i] - b.image(2, 0)[i]);
  EXPECT_GT(diff / double(b.image_floats()), 5.0);
}

TEST(Generate, GrazingLightAcrossTheWalesStripesTheImage) {
  // A grazing light across the wales lights one flank of every wale and leaves the other
  // flank and the groove in shadow: the column means (the wale profile) swing strongly. The
  // same light along the wales (azimuth 90) lights every column alike.
  GenerateConfig c = small("corduroy", 32);
  c.hdr = true;
  c.lights = DirectionSet({{75, 0}, {75, 90}});
  c.views = DirectionSet({{0, 0}});
  const Btf b = generate(c);
  const auto profile_variation = [&](std::size_t l) {
    std::vector<double> col(32, 0.0);
    double all = 0.0;
    for (int x = 0; x < 32; ++x)
      for (int y = 0; y < 32; ++y)
        for (int ch = 0; ch < 3; ++ch) col[std::size_t(x)] += b.at(l, 0, x, y, ch);
    for (double v : col) all += v;
    const double m = all / 32.0;
    double var = 0.0;
    for (double v : col) var += (v - m) * (v - m);
    return std::sqrt(var / 32.0) / m;
  };
  EXPECT_GT(profile_variation(0), 0.5);
  EXPECT_GT(profile_variation(0), 2.0 * profile_variation(1));
}

TEST(Generate, ViewParallaxChangesTheImage) {
  for (const auto& material : material_names()) {
    GenerateConfig c = small(material, 24);
    c.lights = DirectionSet({{0, 0}});
    c.views = DirectionSet({{0, 0}, {60, 0}});
    const Btf b = generate(c);
    double diff = 0.0;
    for (std::size_t i = 0; i < b.image_floats(); ++i)
      diff += std::abs(b.image(0, 0)[i] - b.image(0, 1)[i]);
    EXPECT_GT(diff / double(b.image_floats()), 5.0) << material;
  }
}

TEST(Generate, ParallaxAcrossTheWalesChangesMoreThanAlongThem) {
  // Relief, not a flat texture: an oblique view across the corduroy wales displaces and masks
  // them (a different image); the same elevation along the wales slides the view along the
  // ridges, where the relief hardly changes.
  GenerateConfig c = small("corduroy", 32);
  c.hdr = true;
  c.lights = DirectionSet({{0, 0}});
  c.views = DirectionSet({{0, 0}, {60, 0}, {60, 90}});
  const Btf b = generate(c);
  const auto diff = [&](std::size_t v) {
    double d = 0.0;
    for (std::size_t i = 0; i < b.image_floats(); ++i)
      d += std::abs(b.image(0, 0)[i] - b.image(0, v)[i]);
    return d / double(b.image_floats());
  };
  EXPECT_GT(diff(1), 1.5 * diff(2));
}

TEST(Generate, MirrorViewShowsAHighlight) {
  // Leather (glossy): the view at the mirror direction of the light is brighter than a view
  // far from it at the same elevation.
  for (const double theta : {30.0, 45.0, 60.0}) {
    GenerateConfig c = small("leather", 24);
    c.hdr = true;
    c.lights = DirectionSet({{theta, 0}});
    c.views = DirectionSet({{theta, 180}, {theta, 90}});
    const Btf b = generate(c);
    EXPECT_GT(mean(b, 0, 0), 1.3 * mean(b, 0, 1)) << theta;
  }
}

TEST(Generate, TheImageWrapsWithoutASeam) {
  // Across the wrap (last column to first, last row to first) the image changes no more than
  // between neighbouring columns and rows inside it, summed over several images.
  for (const auto& material : material_names()) {
    GenerateConfig c = small(material, 32);
    c.lights = DirectionSet({{0, 0}, {60, 30}, {75, 0}});
    c.views = DirectionSet({{0, 0}, {45, 200}});
    const Btf b = generate(c);
    double seam_cols = 0.0, seam_rows = 0.0, inner_cols = 0.0, inner_rows = 0.0;
    double same_phase_cols = 0.0;
    for (std::size_t l = 0; l < b.lights().size(); ++l)
      for (std::size_t v = 0; v < b.views().size(); ++v) {
        for (int k = 0; k + 1 < 32; ++k) {
          inner_cols += column_difference(b, l, v, k, k + 1) / 31.0;
          inner_rows += row_difference(b, l, v, k, k + 1) / 31.0;
        }
        for (int k = 7; k < 31; k += 8)
          same_phase_cols += column_difference(b, l, v, k, k + 1) / 3.0;
        seam_cols += column_difference(b, l, v, 31, 0);
        seam_rows += row_difference(b, l, v, 31, 0);
      }
    EXPECT_LE(seam_rows, 2.0 * inner_rows) << material;
    if (material == "corduroy") {
      // The wales have sharp shadow edges at a fixed place, so the seam may fall on one. With
      // 4 wales of 8 pixels, columns 31|0 have the pattern phase of 7|8, 15|16 and 23|24: the
      // seam must look like those.
      EXPECT_LE(seam_cols, 1.5 * same_phase_cols + 5.0);
      EXPECT_GE(seam_cols, same_phase_cols / 1.5 - 5.0);
    } else {
      EXPECT_LE(seam_cols, 2.0 * inner_cols) << material;
    }
  }
}

TEST(Generate, CorduroyPeriodDividesTheSize) {
  // 24 pixels: 3 wales of 8 pixels; the column profile repeats with period 8.
  GenerateConfig c = small("corduroy", 24);
  c.lights = DirectionSet({{45, 0}});
  c.views = DirectionSet({{0, 0}});
  const Btf b = generate(c);
  std::vector<double> p(24, 0.0);
  for (int x = 0; x < 24; ++x)
    for (int y = 0; y < 24; ++y) p[std::size_t(x)] += b.at(0, 0, x, y, 0) / 24.0;
  double same = 0.0, other = 0.0;
  for (int x = 0; x < 24; ++x) {
    same += std::abs(p[std::size_t(x)] - p[std::size_t((x + 8) % 24)]);
    other += std::abs(p[std::size_t(x)] - p[std::size_t((x + 4) % 24)]);
  }
  EXPECT_LT(same, 0.5 * other);
}

TEST(Generate, RejectsBadRequests) {
  GenerateConfig c = small("velvet", 16);
  try {
    generate(c);
    FAIL() << "no error for an unknown material";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), Error::Kind::kArgument);
    EXPECT_NE(std::string(e.what()).find("unknown material 'velvet'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("corduroy, knit, bumps"), std::string::npos);
  }
  c = small("corduroy", 3);
  EXPECT_THROW(generate(c), Error);
  c.size = 8193;
  EXPECT_THROW(generate(c), Error);
  c = small("corduroy", 16);
  c.supersample = 0;
  EXPECT_THROW(generate(c), Error);
  c.supersample = 9;
  EXPECT_THROW(generate(c), Error);
  c = small("corduroy", 16);
  c.lights = DirectionSet();
  EXPECT_THROW(generate(c), Error);
}

TEST(Generate, SupersamplingOneAndFourBothWork) {
  GenerateConfig c = small("bumps", 16);
  c.lights = DirectionSet({{30, 60}});
  c.views = DirectionSet({{0, 0}});
  c.supersample = 1;
  const Btf one = generate(c);
  c.supersample = 4;
  const Btf four = generate(c);
  // Same scene, different anti-aliasing: close on average, not identical.
  EXPECT_FALSE(same_bytes(one, four));
  EXPECT_LT(std::abs(mean(one, 0, 0) - mean(four, 0, 0)), 5.0);
}

}  // namespace
}  // namespace btfgmm
