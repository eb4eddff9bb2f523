// The settings of a fit of any method, with their defaults, and the fit they ask for.
#include "btfgmm/methods/fit_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {
namespace {

Precision mixture_precision(const std::string& text) {
  if (text.empty() || text == "compact" || text == "q8") return Precision::kCompact;
  if (text == "f32") return Precision::kF32;
  if (text == "f16") return Precision::kF16;
  throw Error(Error::Kind::kArgument,
              fmt::format("--precision '{}': the Gaussian mixture stores compact (the default: "
                          "quantised, zstd), f32 or f16",
                          text));
}

// The mixture, as run_fit fits it but for the file.
std::unique_ptr<Representation> fit_mixture(const FitOptions& o, const std::string& input,
                                            std::shared_ptr<const BtfSource> source,
                                            const Tile& tile, const FitProgress& progress) {
  FitRequest r = mixture_fit_request(o, input, "");
  r.tile = tile;
  r.source = std::move(source);
  r.config.em.stop = progress.stop;
  FitObserver observer;
  observer.started = progress.started;
  observer.iteration = progress.iteration;
  if (progress.progress)
    observer.refinement = [&progress](const GradientProgress& g) {
      progress.progress(g.fraction, "refinement");
    };
  FitOutcome fit = fit_in_memory(r, observer);
  if (fit.interrupted) return nullptr;
  return std::make_unique<GaussianMixture>(std::move(fit.model));
}

}  // namespace

void set_refine_steps(FitConfig& config, int steps) {
  if (steps < 0 || steps > kMaxRefineSteps)
    throw Error(Error::Kind::kArgument,
                fmt::format("--refine-steps {}: give 1 to {} Adam steps, or leave it out for as "
                            "many as the fit affords",
                            steps, kMaxRefineSteps));
  if (steps > 0 && config.objective != FitObjective::kPrediction)
    throw Error(Error::Kind::kArgument,
                "--refine-steps applies to the objective prediction only (the paper's EM, "
                "--objective likelihood, refines nothing); leave one of them out");
  config.refinement_steps = steps;
}

FitRequest mixture_fit_request(const FitOptions& o, const std::string& input,
                               const std::string& output) {
  if (o.clusters != 0 || o.degree != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} applies to {} only, not to the Gaussian mixture; leave it out",
                            o.clusters ? "--clusters" : "--degree",
                            o.clusters ? "--method lpca" : "--method plm-rf"));
  if (o.levels != 0)
    throw Error(Error::Kind::kArgument,
                "--levels applies to the pyramid of --method 3d-car, 2d-car or gmrf only, not "
                "to the Gaussian mixture; leave it out");
  FitRequest r;
  r.input = input;
  r.output = output;
  r.config.components = o.components ? o.components : 600;
  r.config.seed = o.seed;
  r.config.em.max_iterations = o.iterations ? o.iterations : 40;
  r.config.em.epsilon = o.epsilon.value_or(0.0);
  r.config.em.threads = o.threads;
  r.config.objective =
      parse_objective(o.objective.empty() ? "prediction" : o.objective, "--objective");
  set_refine_steps(r.config, o.refine_steps);
  if (o.refine_seconds > 0) r.config.refinement_seconds = o.refine_seconds;
  r.precision = mixture_precision(o.precision);
  return r;
}

MethodSettings method_settings(const FitOptions& o, const MethodInfo& method) {
  if (o.epsilon || !o.objective.empty() || o.refine_steps != 0 || o.refine_seconds != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} cannot apply to --method {}: it belongs to the Gaussian "
                            "mixture's fit (--method gm) only; leave it out",
                            o.epsilon               ? "--epsilon"
                            : o.refine_steps != 0   ? "--refine-steps"
                            : o.refine_seconds != 0 ? "--refine-seconds"
                                                    : "--objective",
                            method.name));
  if (o.levels != 0 && !method.pyramid)
    throw Error(Error::Kind::kArgument,
                fmt::format("--levels {} cannot apply to --method {}: it has no pyramid (--levels "
                            "applies to 3d-car, 2d-car and gmrf); leave it out",
                            o.levels, method.name));
  MethodSettings s;
  s.components = o.components;
  s.levels = o.levels;
  s.clusters = o.clusters;
  s.degree = o.degree;
  s.iterations = o.iterations;
  s.seed = o.seed;
  s.threads = o.threads;
  // 8 bits a factor by default: at most 0.1 dB below f32 on generated tiles (docs/METHODS.md).
  s.encoding =
      o.precision.empty() ? method.fit_encoding : parse_factor_encoding(o.precision, "--precision");
  return s;
}

std::unique_ptr<Representation> fit_representation(const FitOptions& o, const std::string& input,
                                                   std::shared_ptr<const BtfSource> source,
                                                   const Tile& tile, const FitProgress& progress) {
  if (o.method == kMixtureMethod) return fit_mixture(o, input, std::move(source), tile, progress);
  const MethodInfo& method = find_method(o.method);
  MethodSettings s = method_settings(o, method);
  s.progress = progress.progress;
  s.stop = progress.stop;
  if (!source) source = std::make_shared<const BtfSource>(BtfSource::open(input));
  const BtfInfo& info = source->info();
  const Btf btf = source->load(tile.empty() ? Tile{0, 0, info.width, info.height} : tile);
  if (progress.started)
    progress.started(FitTile{btf.lights(), btf.views(), btf.origin(), btf.format()});
  return fit_and_record(method, btf, s, fingerprint_of(btf, {input, info.width, info.height}));
}

}  // namespace btfgmm
