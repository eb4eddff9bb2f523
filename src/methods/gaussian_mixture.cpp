// The Gaussian mixture behind the Representation interface.
#include "btfgmm/methods/gaussian_mixture.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/predict_gpu.hpp"
#include "btfgmm/model/refine.hpp"

namespace btfgmm {

GaussianMixture::GaussianMixture(BtfModel model) : model_(std::move(model)) {
  set_provenance(std::move(model_.provenance));  // the Representation's is the one
  model_.provenance = {};
  frame_.lights = model_.lights;
  frame_.views = model_.views;
  frame_.width = model_.width;
  frame_.height = model_.height;
  frame_.origin = model_.origin;
  frame_.format = model_.format;
}

std::string_view GaussianMixture::method() const {
  return kMixtureMethod;
}

std::string GaussianMixture::size_text() const {
  return fmt::format("M = {}", model_.mixture.size());
}

std::uint64_t GaussianMixture::parameter_count() const {
  return std::uint64_t(model_.mixture.size()) * kVariables * 2 +
         std::uint64_t(model_.mean_brdf.size());
}

void GaussianMixture::predict(std::span<const Query> queries, std::span<float> rgb) const {
  if (device_)
    btfgmm::predict(*device_, model_, queries, rgb);
  else
    btfgmm::predict(model_, queries, rgb);
}

Btf GaussianMixture::decode(const DirectionSet& lights, const DirectionSet& views, int width,
                            int height, double tolerance) const {
  if (device_) return btfgmm::decode(*device_, model_, lights, views, width, height);
  return btfgmm::decode(model_, lights, views, width, height, tolerance);
}

bool GaussianMixture::compute_on(std::shared_ptr<ComputeDevice> device) {
  device_ = std::move(device);
  return true;
}

std::uint32_t GaussianMixture::file_flags() const {
  return mixture_file_flags(model_);
}

std::vector<std::uint8_t> GaussianMixture::payload() const {
  return mixture_payload(model_);
}

namespace {

// The unit of each variable (docs/ALGORITHM.md, "Units and the variance floor"): what a
// value of 1 in the model means, for reading L and the parameters.
std::string units_text(const BtfModel& m) {
  const auto& u = m.scaling.unit;
  const double deg = 180.0 / 3.14159265358979323846;
  const std::string colour =
      m.format == SampleFormat::kHdr
          ? fmt::format("{:.4g} (1/255 of the data's range)", u[6])
          : (u[6] == 1.0 ? std::string("1 level of 0-255") : fmt::format("{:.4g} levels", u[6]));
  return fmt::format(
      "x, y {:g} pixel; light angles {:.3g} deg and view angles {:.3g} deg (each "
      "set's sampling step); colour {}",
      u[0], u[2] * deg, u[4] * deg, colour);
}

}  // namespace

std::vector<std::pair<std::string, std::string>> GaussianMixture::details() const {
  const FitSettings& s = model_.settings;
  return {
      {"components", fmt::format("{} ({} requested, {} dropped by EM)", model_.mixture.size(),
                                 s.components, s.dropped)},
      {"fit", fmt::format("{} of at most {} EM iterations, epsilon {:g}, seed {}", s.iterations,
                          s.max_iterations, s.epsilon, s.seed)},
      {"log-lik.", fmt::format("{:.6f} nats per sample, L of Eq. (3) for the parameters stored "
                               "(the density of the 9 variables, each in its model unit)",
                               s.log_likelihood)},
      {"model units", units_text(model_)},
      {"precision", std::string(precision_text(model_.precision))},
  };
}

FactorEncoding GaussianMixture::encoding() const {
  // The compact file quantises every parameter with a stated step (docs/FORMAT.md).
  return model_.precision == Precision::kF16       ? FactorEncoding::kF16
         : model_.precision == Precision::kCompact ? FactorEncoding::kCompact
                                                   : FactorEncoding::kF32;
}

std::unique_ptr<Representation> fit_gaussian_mixture(const Btf& tile, const FitOptions& s) {
  // The one route from the options to the mixture's fit (its defaults and its file).
  const FitRequest request = mixture_fit_request(s, "", "");
  FitConfig config = request.config;
  config.em.stop = s.stop;
  EmCallback progress;
  FitObserver watch;
  if (s.progress) {
    progress = [&s](const EmProgress& p) {
      s.progress(double(p.iteration) / double(p.max_iterations), "EM");
    };
    watch.refinement = [&s](const GradientProgress& p) {
      s.progress(p.fraction, p.colour_refit ? "refinement, colour refit" : "refinement");
    };
  }
  BtfModel model = fit_model(tile, config, progress, nullptr, {}, nullptr, &watch);
  // Stopped in EM (no model) or in the refinement (a model of fewer steps): stopped either way.
  if (model.mixture.size() == 0 || (s.stop && s.stop->load()))
    throw Error(Error::Kind::kArgument, "the Gaussian mixture's fit was stopped");
  model.precision = request.precision;
  return std::make_unique<GaussianMixture>(std::move(model));
}

namespace {

const GaussianMixture& mixture_of(const Representation& model, std::string_view what) {
  const auto* mixture = dynamic_cast<const GaussianMixture*>(&model);
  if (!mixture)
    throw Error(Error::Kind::kArgument,
                fmt::format("a {} model cannot be stored {}: only a Gaussian mixture (gm); give "
                            "one",
                            model.method(), what));
  return *mixture;
}

}  // namespace

FitOptions mixture_byte_probe(const FitOptions& s) {
  FitOptions probe = s;
  probe.objective = "likelihood";
  probe.iterations = kProbeIterations;
  probe.epsilon.reset();
  probe.refine_steps = 0;
  probe.refine_seconds = 0.0;
  probe.refine_epochs = 0;
  return probe;
}

FitOptions mixture_budget_choice(FitOptions s, std::span<const std::string_view> given) {
  if (std::find(given.begin(), given.end(), "iterations") == given.end())
    s.iterations = kBudgetIterations;
  return s;
}

std::size_t mixture_most_components(const ModelFrame& frame, const FitOptions& s) {
  if (mixture_fit_request(s, "", "").config.objective != FitObjective::kPrediction)
    return std::numeric_limits<std::size_t>::max();
  return supported_components(frame.pixels() * frame.lights.size() * frame.views.size());
}

std::unique_ptr<Representation> mixture_without_components(const Representation& model) {
  BtfModel m = mixture_of(model, "without its components").model();
  m.mixture = ProductMixture{};
  auto out = std::make_unique<GaussianMixture>(std::move(m));
  out->set_provenance(model.provenance());
  return out;
}

std::unique_ptr<Representation> coarsened_mixture(const Representation& model, double factor) {
  if (!(factor >= 1.0) || !std::isfinite(factor))
    throw Error(Error::Kind::kArgument,
                fmt::format("a mixture's steps can be made coarser by a factor of 1 or more, "
                            "not {}; give such a factor",
                            factor));
  BtfModel m = mixture_of(model, "with coarser steps").model();
  for (double* step : {&m.compact_steps.log_weight, &m.compact_steps.log_sigma,
                       &m.compact_steps.input_mean, &m.compact_steps.colour_mean})
    *step *= factor;
  auto out = std::make_unique<GaussianMixture>(std::move(m));
  out->set_provenance(model.provenance());
  return out;
}

}  // namespace btfgmm
