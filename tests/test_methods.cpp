// The one interface for every representation: the mixture behind it, the registry, the model
// file's method tag, factor storage and the interpolation shared by the image methods.
#include <gtest/gtest.h>
#include <zlib.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/measured_images.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "methods/factors.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

using test::error_of;

BtfModel golden_mixture() {
  return load_model(std::filesystem::path(BTFGMM_TEST_DATA) / "golden_v1.btfgmm");
}

TEST(Methods, TheMixtureBehindTheInterfaceIsTheMixture) {
  const BtfModel m = golden_mixture();
  const GaussianMixture gm(m);
  EXPECT_EQ(gm.method(), "gm");
  EXPECT_EQ(gm.frame().width, m.width);
  EXPECT_EQ(gm.paper_ratio(), m.compression_ratio_paper());
  EXPECT_EQ(gm.parameter_count(), m.mixture.size() * 18 + m.mean_brdf.size());
  const Query q[] = {{.x = 1.5, .y = 2.25, .light = {40, 90}, .view = {0, 0}},
                     {.x = 3.9, .y = 3.9, .light = {80, 300}, .view = {20, 10}}};
  float rgb[6];
  gm.predict(q, rgb);
  for (int i = 0; i < 2; ++i) {
    const auto want = predict(m, q[i]);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(rgb[i * 3 + c], want[std::size_t(c)]);
  }
  // Its file is the mixture's file; read back through the registry, the same model.
  const auto bytes = representation_file_bytes(gm);
  EXPECT_EQ(bytes, serialize_model(m));
  const auto back = read_representation(bytes, "gm.btfgmm");
  EXPECT_EQ(back->method(), "gm");
  EXPECT_EQ(representation_file_bytes(*back), bytes);
}

// A stop asked for once EM is done ends the mixture's fit within its refinement for the
// prediction, and the fit says it stopped (a sweep or a budget must not take a model of
// fewer steps as done); unstopped, the same fit gives its model.
TEST(Methods, AStopDuringTheMixturesRefinementStopsItsFit) {
  const Btf tile = test::generated_tile("knit", 6, 5, "rings:0/1,40/6", "rings:0/1,40/3");
  std::atomic<bool> stop{false};
  FitOptions s;
  s.components = 4;
  s.iterations = 2;
  s.stop = &stop;
  s.progress = [&stop](double fraction, std::string_view stage) {
    if (stage == "EM" && fraction >= 1.0) stop.store(true);  // after EM's last iteration
  };
  EXPECT_NE(error_of([&] { fit_gaussian_mixture(tile, s); }).find("fit was stopped"),
            std::string::npos);
  stop.store(false);
  s.progress = {};
  EXPECT_EQ(fit_gaussian_mixture(tile, s)->method(), "gm");
}

TEST(Methods, UnknownNamesAreRefusedWithTheListAndASuggestion) {
  const std::string msg = error_of([] { find_method("gn"); });
  EXPECT_NE(msg.find("unknown method 'gn'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("did you mean 'gm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("the methods are: gm"), std::string::npos) << msg;
  EXPECT_EQ(find_method("gm").name, "gm");
  EXPECT_EQ(all_methods()[0].name, "gm");
}

// A file with the payload of `method` replaced by `payload`, checksum made right.
std::vector<std::uint8_t> file_of(std::string_view method, std::span<const std::uint8_t> payload) {
  return model_file_bytes(method, 0, {}, payload);
}

TEST(Methods, TheMethodTagIsCheckedAndAnUnknownOneNamed) {
  const std::vector<std::uint8_t> nothing;
  std::string msg = error_of([&] { read_representation(file_of("zz-new", nothing), "z.btfgmm"); });
  EXPECT_NE(msg.find("'z.btfgmm' holds a 'zz-new' model"), std::string::npos) << msg;
  EXPECT_NE(msg.find("use a newer btfgmm"), std::string::npos) << msg;
  msg = error_of([&] { read_representation(file_of("GM", nothing), "u.btfgmm"); });
  EXPECT_NE(msg.find("a-z, 0-9 and '-'"), std::string::npos) << msg;
  msg = error_of([&] { read_representation(file_of("", nothing), "e.btfgmm"); });
  EXPECT_NE(msg.find("method name of 0 bytes"), std::string::npos) << msg;
  // A mixture's reader refuses another method's file, naming it.
  msg = error_of([&] { deserialize_model(file_of("pca-btf", nothing), "p.btfgmm"); });
  EXPECT_NE(msg.find("holds a 'pca-btf' model, not a Gaussian mixture"), std::string::npos) << msg;
}

// Files of every comparison method as version 2 wrote them (a 4 x 4 knit tile, seed 7, 7
// lights x 4 views: `btfgmm generate --material knit --size 4 --seed 7 --lights
// rings:0/1,40/6 --views rings:0/1,40/3`, then `fit --method M`): they read, hold the same
// payload when written again, and predict what they predicted when written, at a measured
// pair and between directions.
TEST(Methods, VersionTwoFilesOfEveryMethodStillRead) {
  struct Golden {
    const char* method;
    std::size_t parameters;
    float measured[3], between[3];
  };
  const Golden golden[] = {
      {.method = "pca-btf",
       .parameters = 200,
       .measured = {132.517059f, 123.083794f, 107.801353f},
       .between = {130.583527f, 121.018936f, 105.997276f}},
      {.method = "pca-rf",
       .parameters = 632,
       .measured = {120.677750f, 111.981506f, 97.941696f},
       .between = {123.412422f, 114.467224f, 100.102104f}},
      {.method = "lpca",
       .parameters = 552,
       .measured = {137.156021f, 127.572594f, 111.883621f},
       .between = {128.965805f, 119.649498f, 104.816185f}},
      {.method = "ptm-rf",
       .parameters = 1152,
       .measured = {115.656845f, 107.492050f, 93.834244f},
       .between = {131.490921f, 122.026833f, 106.925919f}},
      {.method = "plm-rf",
       .parameters = 1212,
       .measured = {117.798912f, 109.438629f, 95.529449f},
       .between = {133.204529f, 123.613876f, 108.310684f}},
  };
  for (const Golden& g : golden) {
    SCOPED_TRACE(g.method);
    const std::filesystem::path path = std::filesystem::path(BTFGMM_TEST_DATA) /
                                       (std::string("golden_v2_") + g.method + ".btfgmm");
    std::ifstream in(path, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                          std::istreambuf_iterator<char>());
    const ModelFileContents file = open_model_file(bytes, path.string());
    EXPECT_EQ(file.version, 2u);
    EXPECT_EQ(file.method, g.method);
    const auto model = load_representation(path);
    EXPECT_EQ(model->method(), g.method);
    EXPECT_EQ(model->parameter_count(), g.parameters);
    EXPECT_EQ(model->frame().width, 4);
    EXPECT_EQ(model->frame().lights.size(), 7u);
    EXPECT_EQ(model->frame().views.size(), 4u);
    const std::vector<std::uint8_t> payload = model->payload();
    EXPECT_TRUE(
        std::equal(payload.begin(), payload.end(), file.payload.begin(), file.payload.end()));
    const Query queries[] = {{.x = 1, .y = 2, .light = {40, 60}, .view = {40, 120}},
                             {.x = 2.5, .y = 0.25, .light = {25, 75}, .view = {10, 200}}};
    float rgb[6];
    model->predict(queries, rgb);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(rgb[c], g.measured[c], 1e-3) << c;
      EXPECT_NEAR(rgb[3 + c], g.between[c], 1e-3) << c;
    }
  }
}

TEST(Factors, Q8IsWithinHalfAStepAndReadsBackBitForBit) {
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0f, 3.0f);
  const std::size_t rows = 5, cols = 97;
  std::vector<float> v(rows * cols);
  for (float& x : v) x = n(rng);
  for (auto e : {FactorEncoding::kF32, FactorEncoding::kF16, FactorEncoding::kQ8}) {
    std::vector<float> q = v;
    detail::quantise_factors(q, cols, e);
    for (std::size_t r = 0; r < rows; ++r) {
      const auto [lo, hi] =
          std::minmax_element(v.begin() + long(r * cols), v.begin() + long((r + 1) * cols));
      const double bound = detail::factor_error_bound(e, *lo, *hi);
      for (std::size_t c = 0; c < cols; ++c)
        EXPECT_LE(std::abs(double(q[r * cols + c]) - double(v[r * cols + c])), bound + 1e-6)
            << to_string(e);
    }
    detail::ByteWriter w;
    detail::put_factors(w, q, cols, e);
    EXPECT_EQ(w.bytes.size(), detail::factor_bytes(rows, cols, e));
    detail::ByteReader r(w.bytes, "model file", "f.btfgmm", "fit again");
    const std::vector<float> back = detail::get_factors(r, rows, cols, "factors");
    ASSERT_EQ(back.size(), q.size());
    EXPECT_EQ(std::memcmp(back.data(), q.data(), q.size() * 4), 0) << to_string(e);
    // The wrong shape is refused, naming the field.
    detail::ByteReader r2(w.bytes, "model file", "f.btfgmm", "fit again");
    const std::string msg = error_of([&] { detail::get_factors(r2, rows + 1, cols, "weights"); });
    EXPECT_NE(msg.find("weights: 5 x 97 values where the model needs 6 x 97"), std::string::npos)
        << msg;
  }
  EXPECT_EQ(parse_factor_encoding("q8", "--precision"), FactorEncoding::kQ8);
  const std::string msg = error_of([] { parse_factor_encoding("f8", "--precision"); });
  EXPECT_NE(msg.find("--precision 'f8'"), std::string::npos) << msg;
}

// A factor beyond a 16-bit float's range would be written as infinity: refused by the fit's
// quantisation, which every other encoding accepts.
TEST(Factors, F16RefusesAValueBeyondItsRange) {
  std::vector<float> v = {1.0f, -65504.0f, 2.0f, 70000.0f};
  const std::string why = error_of([&] { detail::quantise_factors(v, 2, FactorEncoding::kF16); });
  EXPECT_NE(why.find("a factor to store as f16 is 70000"), std::string::npos) << why;
  EXPECT_NE(why.find("store it as compact (the default), q8 or f32"), std::string::npos) << why;
  std::vector<float> in_range = {1.0f, -65504.0f, 2.0f, 65504.0f};
  detail::quantise_factors(in_range, 2, FactorEncoding::kF16);
  EXPECT_EQ(in_range[3], 65504.0f);
  for (auto e : {FactorEncoding::kF32, FactorEncoding::kQ8, FactorEncoding::kCompact}) {
    std::vector<float> q = v;
    EXPECT_NO_THROW(detail::quantise_factors(q, 2, e)) << to_string(e);
  }
}

// The measured data itself as a "method": MeasuredImages' interpolation on known values.
class StoredImages final : public MeasuredImages {
 public:
  explicit StoredImages(const Btf& b) : MeasuredImages(ModelFrame::of(b)), btf_(b) {}
  void measured_pixel(std::size_t l, std::size_t v, int x, int y, float* rgb) const override {
    for (int c = 0; c < 3; ++c) rgb[c] = btf_.at(l, v, x, y, c);
  }
  std::string_view method() const override { return "stored"; }
  std::string size_text() const override { return "all"; }
  double size_order() const override { return 1; }
  std::uint64_t parameter_count() const override { return btf_.data().size(); }
  std::vector<std::uint8_t> payload() const override { return {}; }
  FactorEncoding encoding() const override { return FactorEncoding::kF32; }

 private:
  const Btf& btf_;
};

Btf random_btf() {
  Btf b(DirectionSet::parse("rings:0/1,30/4,60/6"), DirectionSet::parse("rings:0/1,40/4"), 5, 4,
        SampleFormat::kLdr8);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 255.0f);
  for (float& x : b.data()) x = u(rng);
  return b;
}

TEST(MeasuredImages, MeasuredPairsAndPixelCentresAreTheStoredValues) {
  const Btf b = random_btf();
  const StoredImages s(b);
  const Btf d = s.decode(b.lights(), b.views(), 5, 4, 0.0);
  EXPECT_EQ(std::memcmp(d.data().data(), b.data().data(), b.data().size() * 4), 0);
  const Query q{.x = 3.0, .y = 2.0, .light = b.lights()[4], .view = b.views()[2]};
  float rgb[3];
  s.predict(std::span(&q, 1), rgb);
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(rgb[c], b.at(4, 2, 3, 2, c));
  // Between pixel centres: bilinear; past the edge the tile wraps to column 0.
  const Query mid{.x = 4.5, .y = 2.0, .light = b.lights()[4], .view = b.views()[2]};
  s.predict(std::span(&mid, 1), rgb);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(rgb[c], 0.5f * (b.at(4, 2, 4, 2, c) + b.at(4, 2, 0, 2, c)), 1e-3f);
}

TEST(MeasuredImages, UnmeasuredDirectionsAreConvexBlendsOfTheirNeighbours) {
  const Btf b = random_btf();
  const StoredImages s(b);
  const DirectionSet light({{45.0, 20.0}}), view({{20.0, 100.0}});
  const Btf d = s.decode(light, view, 7, 6, 0.0);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 7; ++x)
      for (int c = 0; c < 3; ++c) {
        float lo = 1e9f, hi = -1e9f;
        for (std::size_t l = 0; l < b.lights().size(); ++l)
          for (std::size_t v = 0; v < b.views().size(); ++v) {
            lo = std::min(lo, b.at(l, v, x % 5, y % 4, c));
            hi = std::max(hi, b.at(l, v, x % 5, y % 4, c));
          }
        const float got = d.at(0, 0, x, y, c);
        EXPECT_GE(got, lo - 1e-3f);
        EXPECT_LE(got, hi + 1e-3f);
        // The tile repeats.
        EXPECT_EQ(got, d.at(0, 0, x % 5, y % 4, c));
      }
  // predict at a pixel centre agrees with decode at the same directions.
  const Query q{.x = 2.0, .y = 1.0, .light = light[0], .view = view[0]};
  float rgb[3];
  s.predict(std::span(&q, 1), rgb);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], d.at(0, 0, 2, 1, c), 1e-3f);
  const std::string msg = error_of([&] { s.decode(DirectionSet({{95.0, 0.0}}), view, 2, 2, 0); });
  EXPECT_NE(msg.find("not on the upper hemisphere"), std::string::npos) << msg;
}

}  // namespace
}  // namespace btfgmm
