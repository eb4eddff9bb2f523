// fit_model: mean BRDF, samples, initialisation, EM. run_fit: the fit job around it (load the
// tile, checkpoints, resume, the model file).
#include "btfgmm/model/fit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <string>
#include <system_error>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// The model of a finished fit: the tile's directions and extent, the samples' scaling and
// mean BRDF, the mixture, and how it was fitted.
BtfModel model_of(const Btf& btf, const SampleSet& samples, const FitConfig& config,
                  ProductMixture mix, const EmResult& em) {
  BtfModel m;
  m.lights = btf.lights();
  m.views = btf.views();
  m.width = btf.width();
  m.height = btf.height();
  m.origin = btf.origin();
  m.format = btf.format();
  m.scaling = samples.scaling;
  m.mean_brdf = samples.mean_brdf;
  m.mixture = std::move(mix);
  m.settings.components = std::uint32_t(config.components);
  m.settings.max_iterations = std::uint32_t(config.em.max_iterations);
  m.settings.epsilon = config.em.epsilon;
  m.settings.seed = config.seed;
  m.settings.iterations = std::uint32_t(em.iterations);
  m.settings.dropped = std::uint32_t(em.dropped);
  m.settings.log_likelihood = em.final_log_likelihood;
  return m;
}

// ---- The fit job -------------------------------------------------------------------------

Btf load_tile(const FitRequest& r) {
  if (r.source) return r.source->load(r.tile);
  return BtfSource::open(r.input).load(r.tile);
}

// What a checkpoint of this request holds besides the state: the fit's inputs and settings,
// the tile as loaded and the data's fingerprint.
FitCheckpoint checkpoint_of(const FitRequest& r, const Btf& btf, std::uint64_t fingerprint) {
  FitCheckpoint k;
  k.input = r.input;
  k.output = r.output;
  k.tile = btf.origin();
  k.components = r.config.components;
  k.seed = r.config.seed;
  k.max_iterations = r.config.em.max_iterations;
  k.epsilon = r.config.em.epsilon;
  k.precision = r.precision;
  k.data_fingerprint = fingerprint;
  return k;
}

std::string tile_text(const Tile& t) {
  return fmt::format("{},{},{},{}", t.x, t.y, t.width, t.height);
}

// A resume continues the checkpoint's fit: the same data, the same tile and settings.
void check_resume(const FitResume& resume, const FitCheckpoint& now) {
  const FitCheckpoint& was = resume.checkpoint;
  if (was.data_fingerprint != now.data_fingerprint)
    throw Error(Error::Kind::kArgument,
                fmt::format("the data in '{}' is not what checkpoint '{}' was fitted to (it "
                            "changed since); resume with the original data or fit again",
                            now.input, resume.path));
  struct Setting {
    const char* name;
    std::string was, now;
  };
  const Setting settings[] = {
      {"tile", tile_text(was.tile), tile_text(now.tile)},
      {"components", fmt::to_string(was.components), fmt::to_string(now.components)},
      {"seed", fmt::to_string(was.seed), fmt::to_string(now.seed)},
      {"max iterations", fmt::to_string(was.max_iterations), fmt::to_string(now.max_iterations)},
      {"epsilon", fmt::to_string(was.epsilon), fmt::to_string(now.epsilon)},
      {"precision", fmt::to_string(int(was.precision)), fmt::to_string(int(now.precision))}};
  for (const Setting& s : settings)
    if (s.was != s.now)
      throw Error(Error::Kind::kArgument,
                  fmt::format("checkpoint '{}' was fitted with {} {}, not {}; resume with the "
                              "checkpoint's settings or fit again",
                              resume.path, s.name, s.was, s.now));
}

// Saves the state to request.checkpoint every checkpoint_every iterations (none without one).
EmStateCallback periodic_checkpoints(const FitRequest& r, const FitCheckpoint& job) {
  if (r.checkpoint.empty()) return {};
  return [&r, &job](const ProductMixture& mix, const EmResult& result) {
    if (result.iterations % std::max(1, r.checkpoint_every) != 0) return;
    FitCheckpoint k = job;
    k.state = {mix, result};
    save_checkpoint(k, r.checkpoint);
  };
}

// Interrupted: the state goes to the checkpoint (output + ".ckpt" without one).
FitOutcome save_interrupted(const FitRequest& r, FitCheckpoint k, FitState state) {
  FitOutcome out;
  out.interrupted = true;
  out.iterations = state.result.iterations;
  out.checkpoint = r.checkpoint.empty() ? r.output + ".ckpt" : r.checkpoint;
  k.state = std::move(state);
  save_checkpoint(k, out.checkpoint);
  return out;
}

// Finished: the model file, then the checkpoint goes (the model holds the fit's result).
FitOutcome save_finished(const FitRequest& r, BtfModel model) {
  model.precision = r.precision;
  save_model(model, r.output);
  if (!r.checkpoint.empty()) {
    std::error_code ec;
    fs::remove(r.checkpoint, ec);
  }
  FitOutcome out;
  out.file_bytes = fs::file_size(r.output);
  out.model = std::move(model);
  return out;
}

}  // namespace

BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress,
                   const FitState* resume, const EmStateCallback& after_iteration,
                   FitState* state) {
  const auto t0 = Clock::now();
  const SampleSet samples = make_sample_set(btf);
  ProductMixture mix =
      resume ? resume->mixture : initial_mixture(samples, config.components, config.seed);
  const EmResult em = fit_em(samples, mix, config.em, progress, resume ? &resume->result : nullptr,
                             after_iteration);
  if (state) *state = FitState{mix, em};
  if (em.interrupted) return BtfModel{};
  BtfModel m = model_of(btf, samples, config, std::move(mix), em);
  m.settings.seconds = seconds_since(t0);
  return m;
}

FitRequest resume_request(const fs::path& path) {
  FitCheckpoint k = load_checkpoint(path);
  FitRequest r;
  r.input = k.input;
  r.tile = k.tile;
  r.config.components = k.components;
  r.config.seed = k.seed;
  r.config.em.max_iterations = k.max_iterations;
  r.config.em.epsilon = k.epsilon;
  r.precision = k.precision;
  r.output = k.output;
  r.checkpoint = path.string();
  r.resume = FitResume{path.string(), std::move(k)};
  return r;
}

FitOutcome run_fit(const FitRequest& request, const FitObserver& observer) {
  const Btf btf = load_tile(request);
  const FitCheckpoint job = checkpoint_of(request, btf, btf_fingerprint(btf));
  if (request.resume) check_resume(*request.resume, job);
  if (observer.started) observer.started(btf);
  FitState state;
  BtfModel model = fit_model(btf, request.config, observer.iteration,
                             request.resume ? &request.resume->checkpoint.state : nullptr,
                             periodic_checkpoints(request, job), &state);
  if (state.result.interrupted) return save_interrupted(request, job, std::move(state));
  return save_finished(request, std::move(model));
}

}  // namespace btfgmm
