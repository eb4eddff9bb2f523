// The BTF model: the mean BRDF, the residual sample set on its grid, the EM fit of the
// mixture (Eq. 3-7) on that grid, prediction (Eq. 8-11), and the model file.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/btf.hpp"
#include "btfgmm/directions.hpp"
#include "btfgmm/mixture.hpp"

namespace btfgmm {

// The size of one unit of each of the nine variables, in the variable's natural measure:
// pixels for x, y; radians for the onion-slice angles; the colour scale of the data for r,
// g, b. A variable in model units is its natural value divided by its unit.
struct VariableScaling {
  std::array<double, kVariables> unit{1, 1, 1, 1, 1, 1, 1, 1, 1};
};

// The angular sampling step of a direction set: the median over its directions of the
// angle to the nearest other direction, in radians (1 for a single direction).
double angular_sampling_step(const DirectionSet& set);

// The mean BRDF (DESIGN §2.2): for each (light, view), the mean RGB over the tile's pixels,
// light-major, ni * nv * 3 values.
std::vector<float> mean_brdf(const Btf& btf);

// The residual sample set (DESIGN §2.3) without N x 9 numbers: the residual colour of every
// (pixel, light, view) in model units, ordered pixel-major, then light, then view; x, y and
// the angles are implied by the indices and tabulated once.
struct SampleSet {
  int width = 0, height = 0;
  std::size_t lights = 0, views = 0;
  VariableScaling scaling;
  std::vector<float> mean_brdf;                 // ni * nv * 3, in the data's scale
  std::vector<float> residual;                  // N * 3, model units
  std::vector<std::array<double, 2>> light_ab;  // (alpha, beta) per light, model units
  std::vector<std::array<double, 2>> view_ab;   // (alpha, beta) per view, model units

  std::size_t pixels() const { return std::size_t(width) * height; }
  std::size_t size() const { return pixels() * lights * views; }
  // The sample index of (pixel, light, view).
  std::size_t index(std::size_t pixel, std::size_t light, std::size_t view) const {
    return (pixel * lights + light) * views + view;
  }
  // The nine variables of one sample, in model units.
  std::array<double, kVariables> sample(std::size_t i) const;
};

// Builds the sample set of a BTF: mean BRDF, scaling, residuals. Throws Error(kFormat) on a
// non-finite value.
SampleSet make_sample_set(const Btf& btf);

// Random initialisation (seeded): means at M distinct random samples, variances the
// variance of each variable over the sample set divided by M^(1/3), equal weights.
ProductMixture initial_mixture(const SampleSet& samples, std::size_t components,
                               std::uint64_t seed);

// EM, Eq. (3)-(7), on the sample grid (DESIGN §4): per iteration the spatial and angular
// parts of every component's log density are tabulated once, samples are processed in
// blocks, responsibilities folded into sufficient statistics at once (no N x M matrix).
// Statistics are accumulated per fixed chunk of pixels and reduced in a fixed order, so the
// result does not depend on the number of threads.
//
// To resume an interrupted fit, pass the mixture and the EmResult it returned (or that a
// checkpoint holds): iterations continue from result.iterations + 1, and the outcome is bit
// for bit that of an uninterrupted fit. `after_iteration` is called after every M-step with
// the state a resume needs (to write checkpoints).
using EmStateCallback = std::function<void(const ProductMixture&, const EmResult&)>;
EmResult fit_em(const SampleSet& samples, ProductMixture& mixture, const EmConfig& config,
                const EmCallback& progress = {}, const EmResult* resume = nullptr,
                const EmStateCallback& after_iteration = {});

// L of Eq. (3), the mean log-likelihood of the sample set under `mixture`, by fit_em's E pass
// (`threads` 0: all cores).
double mean_log_likelihood(const SampleSet& samples, const ProductMixture& mixture,
                           int threads = 0);

enum class Precision : std::uint32_t { kF32 = 0, kF16 = 1 };

struct FitSettings {
  std::uint32_t components = 0;  // M requested
  std::uint32_t max_iterations = 0;
  double epsilon = 0.0;
  std::uint64_t seed = 0;
  std::uint32_t iterations = 0;  // run
  std::uint32_t dropped = 0;     // components dropped by EM
  double log_likelihood = 0.0;   // final mean log-likelihood (model units)
  double seconds = 0.0;          // fit time (not stored in the model file: files are reproducible)
};

// Everything evaluation needs.
struct BtfModel {
  DirectionSet lights, views;
  int width = 0, height = 0;  // the tile
  Tile origin;                // where the tile was cut from its source
  SampleFormat format = SampleFormat::kLdr8;
  VariableScaling scaling;
  std::vector<float> mean_brdf;  // ni * nv * 3
  ProductMixture mixture;        // model units
  FitSettings settings;
  Precision precision = Precision::kF32;

  // Compression ratio as the paper counts it (DESIGN §2.6): W*H*ni*nv*3 bytes of 8-bit data
  // against M*9*2 floats (4 bytes) plus the mean BRDF as ni*nv*3 bytes.
  double compression_ratio_paper() const;
  // The same data against the bytes of the model file actually written.
  double compression_ratio_file(std::uint64_t file_bytes) const;
};

struct FitConfig {
  std::size_t components = 600;
  std::uint64_t seed = 1;
  EmConfig em;
};

// Where an interrupted fit stands: the mixture after result.iterations iterations.
struct FitState {
  ProductMixture mixture;
  EmResult result;
};

// Mean BRDF, samples, initialisation and EM on a BTF tile. With `resume`, EM continues from
// that state instead of a fresh initialisation (the same tile and settings are the caller's
// to check: see checkpoint.hpp). `after_iteration` as for fit_em. If the fit was interrupted
// (config.em.stop), *state receives where it stands and the returned model is empty.
BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress = {},
                   const FitState* resume = nullptr, const EmStateCallback& after_iteration = {},
                   FitState* state = nullptr);

// ---- prediction, Eq. (8)-(11) -------------------------------------------------------------

// decode()'s default tolerance, levels: a thousandth of an 8-bit level.
constexpr double kDecodeTolerance = 1e-3;

struct Query {
  double x = 0.0, y = 0.0;  // tile pixel coordinates; any real value (the tile repeats)
  Direction light, view;
};

// Predicts the RGB of every query (Eq. 11: conditional expectation of the colour plus the
// mean BRDF, interpolated between measured directions). `rgb` holds 3 floats per query.
void predict(const BtfModel& model, std::span<const Query> queries, std::span<float> rgb);
std::array<float, 3> predict(const BtfModel& model, const Query& query);

// Decodes images of width x height pixels (the tile repeated) for every pair of the given
// light and view sets, on the grid-factored form of Eq. (9) (docs/ALGORITHM.md, "Decoding").
// Components whose weight is bounded so low over a block of pixels that all of them together
// move no value by more than `tolerance` levels (of the data's scale) are skipped; 0 keeps
// every component. The result equals predict()'s within tolerance + 1e-3 levels. Throws
// Error(kArgument) for a direction off the hemisphere or a negative tolerance.
Btf decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views, int width,
           int height, double tolerance = kDecodeTolerance);

// ---- the model file (docs/FORMAT.md) ------------------------------------------------------

constexpr std::uint32_t kModelFormatVersion = 1;

std::vector<std::uint8_t> serialize_model(const BtfModel& model);
// Throws Error(kFormat) naming `name` for a truncated, corrupted or newer-version file.
BtfModel deserialize_model(std::span<const std::uint8_t> bytes, const std::string& name);

// Atomic: written to a temporary file in the same folder, flushed, then renamed.
void save_model(const BtfModel& model, const std::filesystem::path& path);
BtfModel load_model(const std::filesystem::path& path);

}  // namespace btfgmm
