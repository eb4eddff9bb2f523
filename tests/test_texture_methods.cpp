// The methods 3d-car, 2d-car and gmrf: fit, file round trip, truncated files, synthesis of
// any size from a seed, their counts, compare's statistics, and the command.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/utia.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/methods/texture_models.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/synth/generate.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

// A 16 x 16 corduroy tile, 15 lights x 5 views.
const Btf& tile16() {
  static const Btf tile = [] {
    GenerateConfig g;
    g.size = 16;
    g.seed = 4;
    g.supersample = 1;
    g.lights = DirectionSet::parse("rings:0/1,30/6,60/8");
    g.views = DirectionSet::parse("rings:0/1,45/4");
    return generate(g);
  }();
  return tile;
}

std::unique_ptr<Representation> fitted(std::string_view method, std::size_t clusters = 4) {
  FitOptions s;
  s.clusters = clusters;
  s.seed = 9;
  return find_method(method).fit(tile16(), s);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return test::as_the_command_shows(e.what());
  }
  return "";
}

class TextureMethod : public ::testing::TestWithParam<const char*> {};

TEST_P(TextureMethod, FileRoundTripKeepsTheModelAndItsSynthesis) {
  const auto m = fitted(GetParam());
  EXPECT_EQ(m->method(), GetParam());
  EXPECT_TRUE(m->synthesises());
  const auto back = read_representation(representation_file_bytes(*m), "t.btfgmm");
  EXPECT_EQ(back->payload(), m->payload());
  EXPECT_EQ(back->parameter_count(), m->parameter_count());
  const Btf a = m->decode(tile16().lights(), tile16().views(), 16, 16, 0);
  const Btf b = back->decode(tile16().lights(), tile16().views(), 16, 16, 0);
  EXPECT_TRUE(std::equal(a.data().begin(), a.data().end(), b.data().begin()));
}

TEST_P(TextureMethod, CountsLabelsRangeMapAndModels) {
  const auto m = fitted(GetParam());
  const auto& t = dynamic_cast<const TextureModel&>(*m);
  EXPECT_EQ(t.labels().size(), 15u * 5u);
  EXPECT_EQ(t.heights().size(), 16u * 16u);
  // Every subspace holds at least a mean and a variance per colour.
  EXPECT_GT(m->parameter_count(), 15u * 5u + 256u + 4u * 6u);
  EXPECT_DOUBLE_EQ(m->paper_ratio(), 16.0 * 16 * 75 * 3 / double(m->parameter_count()));
  EXPECT_EQ(m->size_text(), "c = 4");
}

TEST_P(TextureMethod, AnySizeFromASeedDeterministically) {
  auto m = fitted(GetParam());
  const DirectionSet light({Direction{30, 60}}), view({Direction{0, 0}});
  const Btf a = m->decode(light, view, 40, 24, 0);
  EXPECT_EQ(a.width(), 40);
  m->set_synthesis_seed(3, "--seed");
  const Btf b = m->decode(light, view, 40, 24, 0);
  const Btf c = m->decode(light, view, 40, 24, 0);
  EXPECT_TRUE(std::equal(b.data().begin(), b.data().end(), c.data().begin()));
  EXPECT_FALSE(std::equal(a.data().begin(), a.data().end(), b.data().begin()));
  // predict reads the synthesis at the tile's size: the same as decoding the tile.
  const Btf tile = m->decode(light, view, 16, 16, 0);
  const Query q{.x = 5, .y = 7, .light = light[0], .view = view[0]};
  float rgb[3];
  m->predict({&q, 1}, rgb);
  for (int ch = 0; ch < 3; ++ch) EXPECT_FLOAT_EQ(rgb[ch], tile.at(0, 0, 5, 7, ch));
  // Between pixels, bilinear.
  const Query half{.x = 5.5, .y = 7, .light = light[0], .view = view[0]};
  m->predict({&half, 1}, rgb);
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(rgb[ch], (tile.at(0, 0, 5, 7, ch) + tile.at(0, 0, 6, 7, ch)) / 2, 1e-3);
}

TEST_P(TextureMethod, EveryTruncatedFileIsRefused) {
  const auto model = fitted(GetParam(), 2);
  const std::vector<std::uint8_t> payload = model->payload();
  for (std::size_t n = 0; n < payload.size(); n += 7) {
    const auto file = model_file_bytes(GetParam(), model->file_flags(), {}, {payload.data(), n});
    const std::string msg = error_of([&] { read_representation(file, "cut.btfgmm"); });
    EXPECT_NE(msg.find("cut.btfgmm"), std::string::npos) << n << ": " << msg;
  }
}

TEST_P(TextureMethod, CompareMeasuresStatistics) {
  const auto m = std::shared_ptr<const Representation>(fitted(GetParam()));
  const ModelComparison c = compare_model(tile16(), m, "m", 0);
  ASSERT_TRUE(c.texture.has_value());
  // The subspace mean restored: each image's colour mean near the data's (levels of 0-255).
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(c.texture->model_mean[std::size_t(ch)], c.texture->data_mean[std::size_t(ch)],
                12.0);
  EXPECT_GT(c.texture->histogram_distance, 0.0);
  EXPECT_LT(c.texture->histogram_distance, 0.8);
  EXPECT_EQ(c.texture->max_lag, 4);
}

INSTANTIATE_TEST_SUITE_P(Methods, TextureMethod, ::testing::Values("3d-car", "2d-car", "gmrf"));

TEST(TextureMethods, SettingsTheyDoNotTakeAreRefused) {
  FitOptions s;
  s.components = 3;
  EXPECT_NE(error_of([&] { find_method("gmrf").fit(tile16(), s); }).find("--components 3: gmrf"),
            std::string::npos);
  GenerateConfig g;
  g.size = 6;
  g.lights = DirectionSet::parse("rings:0/1,30/6");
  g.views = DirectionSet::parse("rings:0/1");
  const Btf small = generate(g);
  EXPECT_NE(error_of([&] { find_method("3d-car").fit(small, {}); }).find("at least 8 x 8"),
            std::string::npos);
}

// A synthesis larger than the tile stays bounded: the estimate of a coarse level, tested for
// stability on its few pixels alone, once grew along the raster order of a 256 x 256 synthesis
// into a saturated checkerboard (standard deviation 127.5 levels against the data's 26).
TEST(TextureMethods, ASynthesisLargerThanTheTileKeepsTheDatasVariance) {
  GenerateConfig g;
  g.material = "knit";
  g.size = 32;
  g.seed = 1;
  g.lights = DirectionSet::parse("spiral:9");
  g.views = DirectionSet::parse("spiral:4");
  const Btf data = generate(g);
  FitOptions s;
  s.clusters = 3;
  s.levels = 2;
  const auto model = find_method("2d-car").fit(data, s);
  const auto deviation = [](std::span<const float> v) {
    double m = 0, q = 0;
    for (float x : v) m += x;
    m /= double(v.size());
    for (float x : v) q += (x - m) * (x - m);
    return std::sqrt(q / double(v.size()));
  };
  const DirectionSet light({Direction{30, 0}}), view({Direction{0, 0}});
  const Btf big = model->decode(light, view, 256, 256, 0);
  const double tile = deviation(data.data()), synthesis = deviation(big.data());
  EXPECT_LT(synthesis, 1.5 * tile) << "data " << tile;
  EXPECT_GT(synthesis, 0.5 * tile) << "data " << tile;
}

// --levels: a model per level of the pyramid, as many levels as the tile holds (16 x 16: 2,
// the coarsest 8 x 8); more is an error naming the option and the most allowed.
TEST(TextureMethods, PyramidLevelsAsAskedWithinWhatTheTileHolds) {
  for (const char* method : {"3d-car", "2d-car", "gmrf"}) {
    SCOPED_TRACE(method);
    FitOptions s;
    s.clusters = 2;
    s.levels = 1;
    const auto one = find_method(method).fit(tile16(), s);
    s.levels = 0;  // the default: 3, or what the tile holds
    const auto two = find_method(method).fit(tile16(), s);
    EXPECT_EQ(dynamic_cast<const TextureModel&>(*one).levels(), 1);
    EXPECT_EQ(dynamic_cast<const TextureModel&>(*two).levels(), 2);
    EXPECT_GT(two->parameter_count(), one->parameter_count());
    const auto details = two->details();
    const auto it = std::find_if(details.begin(), details.end(),
                                 [](const auto& d) { return d.first == "pyramid levels"; });
    ASSERT_NE(it, details.end());
    EXPECT_EQ(it->second, "2 (Gaussian-Laplacian, a model each: 16 x 16, 8 x 8)");
    const auto back = read_representation(representation_file_bytes(*two), "two.btfgmm");
    EXPECT_EQ(back->payload(), two->payload());
    s.levels = 3;
    EXPECT_NE(error_of([&] {
                find_method(method).fit(tile16(), s);
              }).find("--levels 3: a 16 x 16 tile holds at most 2 pyramid levels"),
              std::string::npos);
  }
  // A method without a pyramid refuses --levels; so does the mixture.
  FitOptions o;
  o.method = "pca-btf";
  o.levels = 2;
  EXPECT_NE(error_of([&] { check_fit_options(o, given_fields(o), FitRoute::kNew); })
                .find("--levels cannot apply to --method pca-btf, which does not take it (--levels "
                      "is taken by 3d-car, 2d-car, gmrf)"),
            std::string::npos);
  o.method = "gm";
  EXPECT_NE(error_of([&] {
              check_fit_options(o, given_fields(o), FitRoute::kNew);
            }).find("--levels cannot apply to --method gm"),
            std::string::npos);
}

// --precision sets the range map's storage (the models' parameters stay f32): honoured, not
// ignored.
TEST(TextureMethods, PrecisionSetsTheRangeMapsStorage) {
  FitOptions o;
  o.method = "3d-car";
  o.clusters = 2;
  EXPECT_EQ(default_file_encoding(find_method("3d-car")), FactorEncoding::kF16);
  std::vector<std::size_t> sizes;
  for (const char* p : {"f32", "f16", "q8"}) {
    set_parameter(o, *method_parameter(find_method("3d-car"), "precision"), std::string(p));
    const auto m = find_method("3d-car").fit(tile16(), o);
    EXPECT_EQ(to_string(m->encoding()), p);
    const auto back = read_representation(representation_file_bytes(*m), "p.btfgmm");
    EXPECT_EQ(back->encoding(), m->encoding());
    EXPECT_EQ(back->payload(), m->payload());
    sizes.push_back(m->payload().size());
  }
  // 256 heights: 4, 2 and 1 bytes each (q8 adds its offset and scale).
  EXPECT_EQ(sizes[0] - sizes[1], 512u);
  EXPECT_EQ(sizes[1] - sizes[2], 256u - 8u);
}

TEST(TextureMethods, APixelWiseMethodHasNoSeedAndNoStatistics) {
  FitOptions s;
  s.components = 2;
  auto pca = find_method("pca-btf").fit(tile16(), s);
  EXPECT_FALSE(pca->synthesises());
  EXPECT_NE(error_of([&] {
              pca->set_synthesis_seed(3, "--seed");
            }).find("--seed: a 'pca-btf' model reproduces its data"),
            std::string::npos);
  const ModelComparison c =
      compare_model(tile16(), std::shared_ptr<const Representation>(std::move(pca)), "p", 0);
  EXPECT_FALSE(c.texture.has_value());
}

TEST(TextureMethods, CommandFitsInfoDecodesWithASeedAndWritesARangeMap) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_texture_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  write_utia(tile16(), dir / "btf");
  const std::string d = dir.string();
  test::CliRun r =
      test::run_cli("fit " + d + "/btf --method 3d-car --clusters 3 -o " + d + "/c.btfgmm", "tex");
  ASSERT_EQ(r.status, 0) << r.err;
  r = test::run_cli("info " + d + "/c.btfgmm", "tex");
  EXPECT_NE(r.out.find("subspaces"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("neighbourhood"), std::string::npos) << r.out;
  r = test::run_cli(
      "decode " + d + "/c.btfgmm -o " + d + "/out --size 20 --seed 3 --light 0,0 --view 0,0",
      "tex");
  EXPECT_EQ(r.status, 0) << r.err;
  r = test::run_cli("compare " + d + "/btf " + d + "/c.btfgmm", "tex");
  EXPECT_NE(r.out.find("mean nothing for it"), std::string::npos) << r.out << r.err;
  EXPECT_NE(r.out.find("histogram"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("streak"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("PSNR (dB)"), std::string::npos) << r.out;
  // render --compare says that its pixel-wise figures mean nothing for a synthesis.
  r = test::run_cli(
      "render " + d + "/c.btfgmm --compare " + d + "/btf --size 48 --json -o " + d + "/fig.png",
      "tex");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"pixelwise_meaningful\":false"), std::string::npos) << r.out;
  r = test::run_cli("render " + d + "/c.btfgmm --compare " + d + "/btf --size 48 --overwrite -o " +
                        d + "/fig.png",
                    "tex");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("synthesis: new texture with the data's statistics, the pixel-wise RMSE, "
                       "PSNR and SSIM are NOT meaningful"),
            std::string::npos)
      << r.err;
  r = test::run_cli("rangemap " + d + "/btf -o " + d + "/range.exr", "tex");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "range.exr"));
  EXPECT_TRUE(fs::exists(dir / "range-normals.png"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm

namespace btfgmm {
namespace {

// Files of each texture method as format version 3 writes them (an 8 x 8 knit tile, seed 7,
// 9 lights x 3 views: `btfgmm generate --material knit --size 8 --seed 7 --lights
// rings:0/1,30/4,60/4 --views rings:0/1,40/2`, then `fit --method M --clusters 2`; also the
// fuzzer's seeds): they read, hold the same payload when written again, and predict what
// they predicted when written, from the seed they store.
TEST(TextureMethods, VersionThreeFilesStillReadAndSynthesiseAlike) {
  struct Golden {
    const char* method;
    std::uint64_t parameters;
    float rgb[3];
  };
  const Golden golden[] = {{"3d-car", 145, {170.479431f, 158.981323f, 139.482208f}},
                           {"2d-car", 141, {191.816223f, 178.623962f, 157.560638f}},
                           {"gmrf", 149, {170.902527f, 159.501328f, 140.577698f}}};
  for (const Golden& g : golden) {
    SCOPED_TRACE(g.method);
    const auto path = std::filesystem::path(BTFGMM_TEST_DATA) /
                      (std::string("golden_v3_") + g.method + ".btfgmm");
    const auto model = load_representation(path);
    EXPECT_EQ(model->method(), g.method);
    EXPECT_EQ(model->parameter_count(), g.parameters);
    const auto again = read_representation(representation_file_bytes(*model), "again");
    EXPECT_EQ(again->payload(), model->payload());
    const Query q{.x = 1, .y = 2, .light = {30, 90}, .view = {40, 180}};
    float rgb[3];
    model->predict({&q, 1}, rgb);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], g.rgb[c], 1e-3) << c;
  }
}

struct Golden {
  const char* method;
  std::uint64_t parameters;
  float rgb[3];
};

// Each golden file of `prefix` reads with `flags`, holds the same payload written again, and
// predicts what it predicted when written.
void expect_golden_files(const char* prefix, const std::vector<Golden>& golden,
                         std::uint32_t flags) {
  for (const Golden& g : golden) {
    SCOPED_TRACE(g.method);
    const auto path =
        std::filesystem::path(BTFGMM_TEST_DATA) / (prefix + std::string(g.method) + ".btfgmm");
    const auto model = load_representation(path);
    EXPECT_EQ(model->method(), g.method);
    EXPECT_EQ(model->file_flags(), flags);
    EXPECT_EQ(model->parameter_count(), g.parameters);
    const auto again = read_representation(representation_file_bytes(*model), "again");
    EXPECT_EQ(again->payload(), model->payload());
    const Query q{.x = 1, .y = 2, .light = {30, 90}, .view = {40, 180}};
    float rgb[3];
    model->predict({&q, 1}, rgb);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], g.rgb[c], 1e-3) << c;
  }
}

// The same tile and fits written as format version 6 (flags kImageMoments: each image's
// moments, the subspaces' marginals, the CAR models solved on the torus). Written again they
// are version 7's (flags 24: the same moments, their codes predicted).
TEST(TextureMethods, VersionSixFilesStillReadAndSynthesiseAlike) {
  expect_golden_files("golden_v6_",
                      {{"3d-car", 505, {178.959213f, 167.598068f, 146.792877f}},
                       {"2d-car", 501, {188.893066f, 176.624924f, 155.234497f}},
                       {"gmrf", 505, {183.315033f, 171.178253f, 151.666275f}}},
                      kImageMoments | kPredictedImageMoments);
}

// The same tile and fits written as format version 7 (flags 24: the moments in steps of a
// level and half a level, predicted from their neighbours; the fuzzer's seeds too).
TEST(TextureMethods, VersionSevenFilesStillReadAndSynthesiseAlike) {
  expect_golden_files("golden_v7_",
                      {{"3d-car", 505, {179.085556f, 168.134262f, 148.400436f}},
                       {"2d-car", 501, {189.116959f, 175.902451f, 155.036438f}},
                       {"gmrf", 505, {183.508682f, 170.465515f, 151.463867f}}},
                      kImageMoments | kPredictedImageMoments);
}

// The same tile and fits written as format version 8 (flags 56: each subspace's relief
// structure added; `btfgmm generate --material knit --size 8 --seed 7 --lights
// rings:0/1,30/4,60/4 --views rings:0/1,40/2`, then `fit --method M --clusters 2 --precision
// f16 --threads 2`).
TEST(TextureMethods, VersionEightFilesStillReadAndSynthesiseAlike) {
  expect_golden_files("golden_v8_",
                      {{"3d-car", 547, {190.286743f, 176.961990f, 155.945114f}},
                       {"2d-car", 541, {195.019394f, 181.048309f, 160.045364f}},
                       {"gmrf", 551, {189.099854f, 175.790059f, 154.933319f}}},
                      kImageMoments | kPredictedImageMoments | kReliefStructure);
}

}  // namespace
}  // namespace btfgmm
