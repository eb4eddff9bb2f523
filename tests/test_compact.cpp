// The mixture's compact encoding (docs/FORMAT.md, "The compact encoding") and the fits for the
// prediction (model/refine.hpp): bounds of the quantisation, the file's size against the
// paper's count, the golden version-4 file, and the colour means' least-squares refit.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/synth/generate.hpp"
#include "model/compact.hpp"

namespace btfgmm {
namespace {

// A generated knit tile of w x w pixels, 7 lights x 4 views.
Btf knit_tile(int w, std::uint64_t seed) {
  GenerateConfig g;
  g.material = "knit";
  g.size = w;
  g.seed = seed;
  g.lights = DirectionSet::parse("rings:0/1,40/6");
  g.views = DirectionSet::parse("rings:0/1,40/3");
  return generate(g);
}

// A fitted model of a small knit tile (EM alone).
BtfModel small_fit(std::size_t components, FitObjective objective = FitObjective::kLikelihood) {
  FitConfig c;
  c.components = components;
  c.seed = 3;
  c.em.max_iterations = 10;
  c.em.threads = 2;
  c.objective = objective;
  return fit_model(knit_tile(8, 5), c);
}

// The RMSE of the model's prediction at every measured sample of `btf`, levels.
double prediction_rmse(const BtfModel& m, const Btf& btf) {
  std::vector<Query> q;
  for (std::size_t l = 0; l < btf.lights().size(); ++l)
    for (std::size_t v = 0; v < btf.views().size(); ++v)
      for (int y = 0; y < btf.height(); ++y)
        for (int x = 0; x < btf.width(); ++x)
          q.push_back({double(x), double(y), btf.lights()[l], btf.views()[v]});
  std::vector<float> rgb(q.size() * 3);
  predict(m, q, rgb);
  double sse = 0.0;
  std::size_t i = 0;
  for (std::size_t l = 0; l < btf.lights().size(); ++l)
    for (std::size_t v = 0; v < btf.views().size(); ++v)
      for (int y = 0; y < btf.height(); ++y)
        for (int x = 0; x < btf.width(); ++x, ++i)
          for (int c = 0; c < 3; ++c) {
            const double d = double(rgb[i * 3 + std::size_t(c)]) - double(btf.at(l, v, x, y, c));
            sse += d * d;
          }
  return std::sqrt(sse / double(rgb.size()));
}

double wrapped(double d, double period) {
  return d - period * std::nearbyint(d / period);
}

// Every parameter read back from a compact file lies within the stated bound of the one
// written: ln w within the log-weight step (half a step, and the renormalisation at most half
// a step), ln sigma within half its step, an input mean within half its step times the sigma
// read, a colour mean and the mean BRDF within half theirs. round_to_compact is the file read
// back, bit for bit.
TEST(Compact, ParametersReadBackWithinTheStatedSteps) {
  BtfModel m = small_fit(9);
  m.precision = Precision::kCompact;
  const BtfModel r = deserialize_model(serialize_model(m), "compact");
  const CompactSteps s;
  ASSERT_EQ(r.mixture.size(), m.mixture.size());
  EXPECT_EQ(r.precision, Precision::kCompact);
  for (std::size_t k = 0; k < m.mixture.size(); ++k) {
    EXPECT_LE(std::abs(std::log(r.mixture.weight[k] / m.mixture.weight[k])), s.log_weight) << k;
    for (int n = 0; n < kVariables; ++n) {
      const double sd = std::sqrt(r.mixture.var[k][n]);
      EXPECT_LE(std::abs(std::log(sd / std::sqrt(m.mixture.var[k][n]))), s.log_sigma / 2 + 1e-12);
      const double period = n == 0 ? 8.0 : n == 1 ? 8.0 : 0.0;
      double d = r.mixture.mean[k][n] - m.mixture.mean[k][n];
      if (period > 0) d = wrapped(d, period);
      const double bound = n < kInputs ? sd * s.input_mean / 2 : s.colour_mean / 2;
      EXPECT_LE(std::abs(d), bound * (1 + 1e-9)) << k << " " << n;
    }
  }
  for (std::size_t i = 0; i < m.mean_brdf.size(); ++i)
    EXPECT_LE(std::abs(r.mean_brdf[i] - m.mean_brdf[i]), s.mean_brdf / 2 + 1e-4) << i;
  const BtfModel rounded = detail::round_to_compact(m);
  EXPECT_EQ(rounded.mixture.weight, r.mixture.weight);
  EXPECT_EQ(rounded.mixture.mean, r.mixture.mean);
  EXPECT_EQ(rounded.mixture.var, r.mixture.var);
  EXPECT_EQ(rounded.mean_brdf, r.mean_brdf);
  EXPECT_EQ(serialize_model(r), serialize_model(m));  // the codes are the same again
}

// A mixture stored with steps `factor` times as coarse (fit --budget's way to bring a file
// within its budget): a smaller file at every factor, each parameter read back within half the
// coarser step of the one fitted; a factor below 1 and another method's model are refused.
TEST(Compact, CoarserStepsGiveSmallerFilesWithinTheCoarserSteps) {
  BtfModel m = small_fit(24);
  m.precision = Precision::kCompact;
  const GaussianMixture fitted(m);
  std::uint64_t bytes_before = representation_file_bytes(fitted).size();
  for (const double factor : {1.5, 2.0, 4.0}) {
    const std::unique_ptr<Representation> coarse = coarsened_mixture(fitted, factor);
    const std::vector<std::uint8_t> file = representation_file_bytes(*coarse);
    EXPECT_LT(file.size(), bytes_before) << factor;
    bytes_before = file.size();
    const std::unique_ptr<Representation> back = read_representation(file, "coarse");
    const auto* read = dynamic_cast<const GaussianMixture*>(back.get());
    ASSERT_NE(read, nullptr);
    const BtfModel& r = read->model();
    const CompactSteps s;
    EXPECT_EQ(r.compact_steps.colour_mean, s.colour_mean * factor);
    EXPECT_EQ(r.compact_steps.mean_brdf, s.mean_brdf);
    ASSERT_EQ(r.mixture.size(), m.mixture.size());
    for (std::size_t k = 0; k < m.mixture.size(); ++k) {
      EXPECT_LE(std::abs(std::log(r.mixture.weight[k] / m.mixture.weight[k])),
                s.log_weight * factor * (1 + 1e-9));
      for (int n = 0; n < kVariables; ++n) {
        const double sd = std::sqrt(r.mixture.var[k][n]);
        EXPECT_LE(std::abs(std::log(sd / std::sqrt(m.mixture.var[k][n]))),
                  s.log_sigma * factor / 2 + 1e-12);
        const double period = n < 2 ? 8.0 : 0.0;
        double d = r.mixture.mean[k][n] - m.mixture.mean[k][n];
        if (period > 0) d = wrapped(d, period);
        const double bound = (n < kInputs ? sd * s.input_mean : s.colour_mean) * factor / 2;
        EXPECT_LE(std::abs(d), bound * (1 + 1e-9)) << factor << " " << k << " " << n;
      }
    }
  }
  EXPECT_THROW(coarsened_mixture(fitted, 0.5), Error);
  FitOptions pca;
  pca.components = 2;
  const std::unique_ptr<Representation> other = find_method("pca-btf").fit(knit_tile(8, 5), pca);
  EXPECT_THROW(coarsened_mixture(*other, 2.0), Error);
}

// The largest difference between two models' predictions at the queries `q`, levels.
double largest_difference(const BtfModel& a, const BtfModel& b, std::span<const Query> q) {
  std::vector<float> pa(q.size() * 3), pb(q.size() * 3);
  predict(a, q, pa);
  predict(b, q, pb);
  double worst = 0.0;
  for (std::size_t i = 0; i < pa.size(); ++i)
    worst = std::max(worst, double(std::abs(pa[i] - pb[i])));
  return worst;
}

// Decoded, the compact model stays within the stated bound of the full-precision one at any
// query: the mixture's rounding within a fraction of a level (measured: 0.22 levels at most
// over these 400, most of them between measured directions and far from the components,
// where the tails decide), the mean BRDF's within half its step (a level), interpolated or
// not (barycentric weights sum to 1), the two added. Its RMSE against the data moves by
// less than 0.01 levels (the mean BRDF's rounding adds a variance of step^2 / 12 to the
// square of an RMSE of tens of levels).
TEST(Compact, DecodesToTheFullPrecisionModelWithinTheBound) {
  const Btf tile = knit_tile(8, 5);
  BtfModel m = small_fit(9);
  const BtfModel r = detail::round_to_compact(m);
  BtfModel mixture_rounded = r;
  mixture_rounded.mean_brdf = m.mean_brdf;
  std::vector<Query> q;
  for (int i = 0; i < 400; ++i)
    q.push_back({0.37 * i, 0.11 * i, {double(i % 80), 7.0 * i}, {double((3 * i) % 75), 11.0 * i}});
  const double mixture = largest_difference(m, mixture_rounded, q);
  const double worst = largest_difference(m, r, q);
  std::printf("compact against full precision: %.4f levels at most, %.4f of them the mixture's\n",
              worst, mixture);
  EXPECT_LT(mixture, 0.5);
  EXPECT_LE(worst, mixture + m.compact_steps.mean_brdf / 2 + 1e-4);
  EXPECT_NEAR(prediction_rmse(r, tile), prediction_rmse(m, tile), 1e-2);
}

// The compact file of the paper's setting (25 x 25 tile, 81 x 81 directions, M = 600) is
// smaller than the paper's count of the same model (62,883 bytes): parameters spread as a
// fit's, a smooth mean BRDF.
TEST(Compact, FileOfThePapersSettingIsWithinThePapersCount) {
  BtfModel m;
  m.lights = DirectionSet::ubo81();
  m.views = DirectionSet::ubo81();
  m.width = m.height = 25;
  m.origin = {.x = 0, .y = 0, .width = 25, .height = 25};
  m.scaling.unit = {1, 1, 0.25, 0.25, 0.25, 0.25, 1, 1, 1};
  m.precision = Precision::kCompact;
  m.mean_brdf.resize(81 * 81 * 3);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  m.mixture.resize(600);
  for (std::size_t k = 0; k < 600; ++k) {
    m.mixture.weight[k] = (0.2 + u(rng)) / 600 / 0.7;
    for (int n = 0; n < kVariables; ++n) {
      const double sd = n < 2 ? 0.3 + 3 * u(rng) : n < 6 ? 0.3 + 2 * u(rng) : 2 + 30 * u(rng);
      m.mixture.var[k][n] = sd * sd;
      m.mixture.mean[k][n] = n < 2 ? 25 * u(rng) : n < 6 ? 12 * u(rng) - 6 : 120 * u(rng) - 60;
    }
  }
  for (std::size_t l = 0; l < 81; ++l)
    for (std::size_t v = 0; v < 81; ++v)
      for (int c = 0; c < 3; ++c)
        m.mean_brdf[(l * 81 + v) * 3 + c] =
            float(40 + 100 * std::cos(DirectionSet::ubo81()[l].theta_deg / 70) *
                           (1 + 0.2 * std::sin(DirectionSet::ubo81()[v].phi_deg / 40 + c)));
  const std::size_t bytes = serialize_model(m).size();
  std::printf("compact file of the paper's setting: %zu bytes\n", bytes);
  EXPECT_LT(double(bytes), paper_model_bytes(81, 81, 600));
}

// Flags 2 came with version 4 and flags 6 with version 5 (which no longer writes 2): a file
// of another version that sets them is refused, and so is the predicted mean BRDF's bit
// without the compact encoding.
TEST(Compact, OlderVersionsWithTheCompactFlagsAreRefused) {
  BtfModel m = small_fit(3);
  m.precision = Precision::kCompact;
  const auto refused = [](std::vector<std::uint8_t> bytes, std::uint8_t version,
                          std::uint8_t flags) {
    bytes[8] = version;
    bytes[12] = flags;
    const auto crc = std::uint32_t(crc32(0L, bytes.data(), uInt(bytes.size() - 4)));
    std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
    try {
      deserialize_model(bytes, "old.btfgmm");
    } catch (const Error& e) {
      return std::string(e.what()).find("unknown flags") != std::string::npos;
    }
    return false;
  };
  std::vector<std::uint8_t> bytes = serialize_model(m);
  EXPECT_EQ(bytes[8], kModelFormatVersion);
  EXPECT_EQ(bytes[12], 2 | kPredictedMeanBrdf);
  EXPECT_TRUE(refused(bytes, 4, 6));
  EXPECT_TRUE(refused(bytes, 3, 2));
  EXPECT_TRUE(refused(bytes, 5, 4));
  EXPECT_TRUE(refused(bytes, 5, 5));
  EXPECT_TRUE(refused(bytes, 5, 2));  // version 5 writes the predicted mean BRDF only
  EXPECT_TRUE(refused(bytes, 5, 8));  // the texture models' flag came with version 6
  // Every truncated prefix is an error.
  const std::vector<std::uint8_t> good = serialize_model(m);
  for (std::size_t n = 0; n < good.size(); ++n)
    EXPECT_THROW(deserialize_model(std::span(good.data(), n), "cut.btfgmm"), Error) << n;
}

// The bytes of a committed golden file.
std::vector<std::uint8_t> golden_bytes(const char* name) {
  std::ifstream in(std::filesystem::path(BTFGMM_TEST_DATA) / name, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A golden compact file's model predicts what it predicted when it was committed.
void expect_predictions(const BtfModel& m, const float (&expected)[2][3]) {
  const Query q[] = {{.x = 1, .y = 2, .light = {40, 60}, .view = {40, 120}},
                     {.x = 2.5, .y = 0.25, .light = {25, 75}, .view = {10, 200}}};
  for (int i = 0; i < 2; ++i) {
    const auto rgb = predict(m, q[i]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], expected[i][c], 1e-3) << i << " " << c;
  }
}

// The golden compact files are a mixture of `btfgmm generate --material knit --size 4 --seed 7
// --lights rings:0/1,40/6 --views rings:0/1,40/3`, then `btfgmm fit -M 6 --iterations 5`.
// Version 4's (its mean BRDF in steps of 1/8, each code less the one before along the views)
// reads, predicts what it predicted, keeps its steps, and written again (the current version,
// the mean BRDF predicted) reads back to the same model, bit for bit.
TEST(Compact, GoldenVersion4FileKeepsDecoding) {
  const std::vector<std::uint8_t> bytes = golden_bytes("golden_v4_gm.btfgmm");
  const BtfModel m = deserialize_model(bytes, "golden_v4_gm.btfgmm");
  EXPECT_EQ(m.precision, Precision::kCompact);
  EXPECT_EQ(m.mixture.size(), 6u);
  EXPECT_EQ(m.compact_steps.mean_brdf, 1.0 / 8.0);
  EXPECT_EQ(recorded_objective(m.provenance), FitObjective::kPrediction);
  expect_predictions(
      m, {{152.589996f, 141.733643f, 124.623924f}, {119.546730f, 110.895248f, 96.906540f}});
  const std::vector<std::uint8_t> v5 = serialize_model(m);
  EXPECT_EQ(v5[8], kModelFormatVersion);
  const BtfModel again = deserialize_model(v5, "v5");
  EXPECT_EQ(again.mean_brdf, m.mean_brdf);
  EXPECT_EQ(again.mixture.weight, m.mixture.weight);
  EXPECT_EQ(again.mixture.mean, m.mixture.mean);
  EXPECT_EQ(again.mixture.var, m.mixture.var);
  EXPECT_LT(v5.size(), bytes.size());  // the predicted mean BRDF takes fewer bytes
}

// A model file's bytes with its provenance's times zeroed, as btfgmm writes them now
// (docs/FORMAT.md, "Provenance"), the CRC made right: fields parsed one by one.
std::vector<std::uint8_t> without_times(std::vector<std::uint8_t> b) {
  const auto u32 = [&b](std::size_t at) {
    std::uint32_t v = 0;
    std::memcpy(&v, b.data() + at, 4);
    return std::size_t(v);
  };
  std::size_t at = 24;
  at += 4 + u32(at);                                  // the method tag
  at += 4;                                            // the provenance's size
  at += 4 + u32(at);                                  // the source
  at += 4 + 4 + 8;                                    // the image size, the content hash
  std::fill_n(b.begin() + std::ptrdiff_t(at), 8, 0);  // the fit's seconds
  at += 8 + 4;                                        // ... and its runs
  const std::size_t settings = u32(at);
  at += 4;
  for (std::size_t k = 0; k < 2 * settings; ++k) at += 4 + u32(at);
  const std::size_t iterations = u32(at);
  at += 4;
  for (std::size_t k = 0; k < iterations; ++k, at += 20)
    std::fill_n(b.begin() + std::ptrdiff_t(at + 8), 8, 0);  // L, the time, the components
  const auto crc = std::uint32_t(crc32(0L, b.data(), uInt(b.size() - 4)));
  std::memcpy(b.data() + b.size() - 4, &crc, 4);
  return b;
}

// Version 5's (the mean BRDF in steps of a level, predicted) reads, writes back to the same
// bytes but the version and the provenance's times (versions 6 and 7 changed the texture models'
// payloads alone), and predicts what it predicted.
TEST(Compact, GoldenVersion5FileKeepsDecoding) {
  const std::vector<std::uint8_t> bytes = golden_bytes("golden_v5_gm.btfgmm");
  const BtfModel m = deserialize_model(bytes, "golden_v5_gm.btfgmm");
  EXPECT_EQ(m.precision, Precision::kCompact);
  EXPECT_EQ(m.mixture.size(), 6u);
  EXPECT_EQ(m.compact_steps.mean_brdf, 1.0);
  std::vector<std::uint8_t> current = bytes;
  current[8] = std::uint8_t(kModelFormatVersion);
  current = without_times(current);
  EXPECT_NE(current, bytes);  // the golden file holds its fit's times
  EXPECT_EQ(serialize_model(m), current);
  expect_predictions(
      m, {{154.550751f, 143.599014f, 126.079483f}, {117.158264f, 108.385704f, 94.593475f}});
}

// ---- the fit for the prediction ---------------------------------------------------------

// The colour means' refit never increases the prediction's error: measured by predict() at
// every sample against the data (independently of the normal equations), and on the normal
// equations' own count, which agrees with it.
TEST(Refine, ColourRefitNeverIncreasesThePredictionError) {
  const Btf tile = knit_tile(8, 5);
  const SampleSet s = make_sample_set(tile);
  for (std::size_t components : {4u, 12u}) {
    BtfModel m = small_fit(components);
    const double before = prediction_rmse(m, tile);
    const ColourNormalEquations eq = colour_normal_equations(s, m.mixture, 2);
    const double n = double(s.size() * 3);
    EXPECT_NEAR(std::sqrt(prediction_squared_error(eq, m.mixture) / n), before, 1e-4);
    const ColourRefit r = refit_colour_means(eq, m.mixture);
    const double after = prediction_rmse(m, tile);
    std::printf("M = %zu: prediction RMSE %.4f -> %.4f levels\n", components, before, after);
    EXPECT_LT(after, before);
    EXPECT_NEAR(std::sqrt(r.error_after / n), after, 1e-4);
    EXPECT_FALSE(r.kept);
    // Refitting again from the optimum changes nothing (up to the pull towards the start).
    const ColourRefit again =
        refit_colour_means(colour_normal_equations(s, m.mixture, 1), m.mixture);
    EXPECT_LE(again.error_after, again.error_before);
    EXPECT_NEAR(again.error_after, r.error_after, 1e-6 * r.error_after);
  }
}

// The validation RMSE the refinement reports is the RMSE of the model's prediction (predict(),
// as decoded) against the data at the held-out samples (validation_sample), counted here
// independently of the refinement's passes; and it is below EM's.
TEST(Refine, ValidationRmseIsTheMeasuredRmseOfTheHeldOutSamples) {
  const Btf tile = knit_tile(8, 5);
  const SampleSet s = make_sample_set(tile);
  BtfModel m = small_fit(12);
  GradientConfig g;
  g.steps = 40;
  const PredictionRefinement r = refine_for_prediction(s, m.mixture, 2, g);
  const std::size_t nl = tile.lights().size(), nv = tile.views().size();
  std::vector<Query> q;
  std::vector<std::array<std::size_t, 4>> at;  // l, v, x, y
  for (std::size_t l = 0; l < nl; ++l)
    for (std::size_t v = 0; v < nv; ++v)
      for (int y = 0; y < tile.height(); ++y)
        for (int x = 0; x < tile.width(); ++x)
          if (validation_sample(std::size_t(y * tile.width() + x), l * nv + v, nl * nv)) {
            q.push_back({double(x), double(y), tile.lights()[l], tile.views()[v]});
            at.push_back({l, v, std::size_t(x), std::size_t(y)});
          }
  ASSERT_EQ(q.size(), r.samples);
  std::vector<float> rgb(q.size() * 3);
  predict(m, q, rgb);
  double sse = 0.0;
  for (std::size_t i = 0; i < q.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double d = double(rgb[i * 3 + std::size_t(c)]) -
                       double(tile.at(at[i][0], at[i][1], int(at[i][2]), int(at[i][3]), c));
      sse += d * d;
    }
  const double measured = std::sqrt(sse / double(3 * q.size()));
  const double reported = btfgmm::prediction_rmse(r.error_final, r.samples);
  std::printf("validation RMSE reported %.5f, measured %.5f levels (EM %.5f)\n", reported, measured,
              btfgmm::prediction_rmse(r.error_em, r.samples));
  EXPECT_NEAR(reported, measured, 1e-3 * measured);
  EXPECT_LT(reported, btfgmm::prediction_rmse(r.error_em, r.samples));
}

// fit_model with the prediction objective: the same EM (its likelihood log is the paper's
// fit's), then a lower prediction error; likelihood reproduces EM alone exactly.
TEST(Refine, PredictionObjectiveStartsFromThePapersFit) {
  const Btf tile = knit_tile(8, 5);
  const BtfModel paper = small_fit(12, FitObjective::kLikelihood);
  const BtfModel refined = small_fit(12, FitObjective::kPrediction);
  ASSERT_EQ(paper.mixture.size(), refined.mixture.size());
  EXPECT_EQ(paper.provenance.fit.iterations.size(), refined.provenance.fit.iterations.size());
  for (std::size_t i = 0; i < paper.provenance.fit.iterations.size(); ++i)
    EXPECT_EQ(paper.provenance.fit.iterations[i].log_likelihood,
              refined.provenance.fit.iterations[i].log_likelihood);
  EXPECT_LT(prediction_rmse(refined, tile), prediction_rmse(paper, tile) - 0.05);
  EXPECT_EQ(parse_objective("likelihood", "--objective"), FitObjective::kLikelihood);
  try {
    parse_objective("likelyhood", "--objective");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--objective 'likelyhood'"), std::string::npos);
  }
}

}  // namespace
}  // namespace btfgmm
