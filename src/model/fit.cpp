// fit_model: mean BRDF, samples, initialisation, EM. run_fit: the fit job around it (load the
// tile, checkpoints, resume, the model file).
#include "btfgmm/model/fit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// The model of a finished fit: the tile's directions and extent, the samples' scaling and
// mean BRDF, the mixture, and how it was fitted.
BtfModel model_of(const FitTile& tile, const SampleSet& samples, const FitConfig& config,
                  ProductMixture mix, const EmResult& em) {
  BtfModel m;
  m.lights = tile.lights;
  m.views = tile.views;
  m.width = tile.origin.width;
  m.height = tile.origin.height;
  m.origin = tile.origin;
  m.format = tile.format;
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
  for (std::size_t i = 0; i < em.log_likelihood.size(); ++i)
    m.provenance.fit.iterations.push_back(
        {em.log_likelihood[i], i < em.seconds.size() ? em.seconds[i] : 0.0,
         i < em.components.size() ? em.components[i] : std::uint32_t(0)});
  return m;
}

// ---- The fit job -------------------------------------------------------------------------

// The frame of a tile in memory.
FitTile tile_of(const Btf& btf) {
  return {
      .lights = btf.lights(), .views = btf.views(), .origin = btf.origin(), .format = btf.format()};
}

// The request's tile as a sample set (read_sample_set), its frame, and the data's
// fingerprint (where it was read from, the tile's content hash).
struct LoadedTile {
  SampleSet samples;
  FitTile tile;
  DataFingerprint data;
};

LoadedTile load_tile(const FitRequest& r) {
  std::shared_ptr<const BtfSource> src = r.source;
  if (!src) src = std::make_shared<const BtfSource>(BtfSource::open(r.input));
  const BtfInfo& info = src->info();
  LoadedTile t;
  t.data.source = {r.input, info.width, info.height};
  t.samples = read_sample_set(*src, r.tile, &t.data.content_hash, r.processes);
  const Tile origin = r.tile.or_whole(info.width, info.height);
  t.tile = {.lights = info.lights, .views = info.views, .origin = origin, .format = info.format};
  return t;
}

// Where EM ran, as the plan and the provenance name it.
std::string device_text(const std::shared_ptr<ComputeDevice>& device) {
  return device ? device->info().description() : "cpu";
}

// The settings of a mixture's fit as its provenance records them.
// Neither the threads nor the processes are recorded: the model is the same with any number of
// either, and so is its file (docs/FORMAT.md, "Provenance").
std::vector<std::pair<std::string, std::string>> settings_record(const FitRequest& r) {
  std::vector<std::pair<std::string, std::string>> s = {
      {"method", "gm"},
      {"components", fmt::to_string(r.config.components)},
      {"iterations", fmt::to_string(r.config.em.max_iterations)},
      {"epsilon", fmt::format("{:g}", r.config.em.epsilon)},
      {"objective", std::string(objective_name(r.config.objective))},
      {"seed", fmt::to_string(r.config.seed)},
      {"precision", std::string(precision_name(r.precision))},
      {"device", device_text(open_compute_device(r.config.device))}};
  if (r.config.refinement_steps > 0)  // --refine-steps, for --continue to refine alike
    s.emplace_back("refine steps", fmt::to_string(r.config.refinement_steps));
  if (r.config.refinement_seconds > 0) {  // --refine-seconds, for --continue alike
    s.emplace_back("refine seconds", fmt::format("{:g}", r.config.refinement_seconds));
    s.emplace_back("reproducible", std::string(kBoundInTime));
  }
  if (r.config.refinement_epochs > 0)  // --refine-epochs, for --continue alike
    s.emplace_back("refine epochs", fmt::to_string(r.config.refinement_epochs));
  if (r.source && r.source->pixel_map())  // a made tile (a seamless cut), not a crop
    s.emplace_back(kTileSetting, r.source->pixel_map()->description);
  return s;
}

// What a checkpoint of this request holds besides the state: the fit's inputs and settings,
// the tile as loaded and the data's fingerprint.
FitCheckpoint checkpoint_of(const FitRequest& r, const Tile& tile, std::uint64_t fingerprint) {
  FitCheckpoint k;
  k.input = r.input;
  k.output = r.output;
  k.tile = tile;
  k.made_from = r.source && r.source->pixel_map() ? r.source->pixel_map()->description : "";
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

// A resume continues the checkpoint's (or the model's) fit: the same data, the same tile and
// settings, at least the iterations already run.
void check_resume(const FitResume& resume, const FitCheckpoint& now) {
  const FitCheckpoint& was = resume.checkpoint;
  const char* what = resume.finished_model ? "model" : "checkpoint";
  if (was.data_fingerprint != now.data_fingerprint)
    throw Error(Error::Kind::kArgument,
                fmt::format("the data in '{}' is not what {} '{}' was fitted to ('{}'; the "
                            "tile's content, size or directions differ); go on with the "
                            "original data or fit again",
                            now.input, what, resume.path, was.input));
  const int done = was.state.result.iterations;
  if (now.max_iterations < done)
    throw Error(Error::Kind::kArgument,
                fmt::format("`iterations` {}: {} '{}' has already run {} iterations; give at "
                            "least {} (the total, not the iterations to add)",
                            now.max_iterations, what, resume.path, done, done));
  struct Setting {
    const char* name;
    std::string was, now;
  };
  const Setting settings[] = {
      {"tile", tile_text(was.tile), tile_text(now.tile)},
      {"components", fmt::to_string(was.components), fmt::to_string(now.components)},
      {"seed", fmt::to_string(was.seed), fmt::to_string(now.seed)},
      {"precision", fmt::to_string(int(was.precision)), fmt::to_string(int(now.precision))}};
  for (const Setting& s : settings)
    if (s.was != s.now)
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} '{}' was fitted with {} {}, not {}; go on with its settings "
                              "or fit again",
                              what, resume.path, s.name, s.was, s.now));
}

// The fit for the prediction refuses, before EM, more components than the tile's training
// samples support (supported_components).
void check_supported_components(const FitConfig& c, std::size_t samples) {
  if (c.objective != FitObjective::kPrediction) return;
  const std::size_t most = supported_components(samples);
  if (c.components <= most) return;
  throw Error(Error::Kind::kArgument,
              fmt::format("{} {}: the tile's {} samples support at most {} components "
                          "for the objective prediction (one per {} training samples, "
                          "docs/ALGORITHM.md); give at most {}, a larger tile, or {} "
                          "likelihood",
                          option_name("components"), c.components, samples, most,
                          kSamplesPerComponent, most, option_name("objective")));
}

// Whether this process writes the fit's files: process 0 of a fit over several.
bool writes_files(const FitRequest& r) {
  return !r.processes || r.processes->rank() == 0;
}

// Saves the state to request.checkpoint every checkpoint_every iterations (none without one).
EmStateCallback periodic_checkpoints(const FitRequest& r, const FitCheckpoint& job) {
  if (r.checkpoint.empty() || !writes_files(r)) return {};
  return [&r, &job](const ProductMixture& mix, const EmResult& result) {
    if (result.iterations % std::max(1, r.checkpoint_every) != 0) return;
    FitCheckpoint k = job;
    k.state = {mix, result};
    save_checkpoint(k, r.checkpoint);
  };
}

// Where an interrupted fit's state goes: the request's checkpoint, else output + ".ckpt"
// (nowhere without either). Returns the path.
std::string save_state(const FitRequest& r, FitCheckpoint k, FitState state) {
  const std::string path = !r.checkpoint.empty() ? r.checkpoint
                           : !r.output.empty()   ? r.output + ".ckpt"
                                                 : std::string();
  k.state = std::move(state);
  if (!path.empty() && writes_files(r)) save_checkpoint(k, path);
  return path;
}

// Interrupted in EM: the outcome names where the state went.
FitOutcome save_interrupted(const FitRequest& r, const FitCheckpoint& k, FitState state) {
  FitOutcome out;
  out.interrupted = true;
  out.iterations = state.result.iterations;
  out.checkpoint = save_state(r, k, std::move(state));
  return out;
}

// The whole fit's provenance: the data, the settings, every run's time and iterations.
void record_provenance(const FitRequest& r, const FitCheckpoint& job, DataFingerprint data,
                       BtfModel& model) {
  Provenance& p = model.provenance;
  p.recorded = true;
  p.data = std::move(data);
  p.fit.settings = settings_record(r);
  p.fit.runs = job.runs;
  p.fit.seconds = model.settings.seconds + (r.resume ? r.resume->seconds_before : 0.0);
}

// The refinement's record: "412 Adam steps in 9 epochs (converged); validation RMSE 9.71
// after EM, 8.02 refined, training RMSE 7.95 (levels; validation: 205031 samples held out,
// 1 in 20; training: 3895594 samples in minibatches of 64928)".
std::pair<std::string, std::string> refinement_record(const PredictionRefinement& r) {
  const char* end = r.stopped       ? " (stopped)"
                    : r.timed_out   ? " (time bound)"
                    : r.step_bound  ? " (step bound)"
                    : r.epoch_bound ? " (epoch bound)"
                                    : "";
  return {"refinement",
          fmt::format("{} Adam steps in {} epochs{}; validation RMSE {:.2f} after EM, {:.2f} "
                      "refined, training RMSE {:.2f} (levels; validation: {} samples held out, "
                      "1 in {}; training: {} samples in minibatches of {})",
                      r.steps, r.epochs, end, prediction_rmse(r.error_em, r.samples),
                      prediction_rmse(r.error_final, r.samples), r.training_rmse, r.samples,
                      kValidationEvery, r.training_samples, r.batch_samples)};
}

// Finished: the model file, then the checkpoint goes (the model holds the fit's result).
void save_finished(const FitRequest& r, FitOutcome& out) {
  if (!writes_files(r)) return;
  save_model(out.model, r.output);
  if (!r.checkpoint.empty() && out.checkpoint.empty()) {
    std::error_code ec;
    fs::remove(r.checkpoint, ec);
  }
  out.file_bytes = fs::file_size(r.output);
}

}  // namespace

namespace {

// EM's first iteration, from components as wide as M equal cells, weighs most of them for
// every sample; later ones, narrower, skip more as negligible: on 25 x 25 tiles of knit and
// corduroy at M = 200 and 600 (2 cores) the 40 iterations took 14 to 21 times the first's
// estimate, an iteration after the first about 0.4 of it (docs/BENCHMARKS.md). The GPU's E
// pass skips none: each iteration takes the first's time.
constexpr double kLaterIterationShare = 0.4;

// The seconds of `iterations` EM iterations from a start whose first is timed at `first`.
double em_seconds(double first, int iterations, bool fresh, bool on_gpu) {
  if (iterations <= 0) return 0.0;
  const double later = fresh && !on_gpu ? kLaterIterationShare : 1.0;
  return first * (1.0 + double(iterations - 1) * later);
}

// The fit's plan on its samples, from the mixture EM starts from: EM's iterations left after
// `done`, one timed on a few lights, and the refinement's bounds and time.
FitPlan plan_fit(const SampleSet& samples, const FitConfig& config, const ProductMixture& start,
                 int done, const std::shared_ptr<ComputeDevice>& device) {
  FitPlan plan{.components = config.components,
               .iterations = std::max(0, config.em.max_iterations - done),
               .em_iteration_seconds =
                   estimate_em_iteration_seconds(samples, start, config.em.threads, device),
               .refines = config.objective == FitObjective::kPrediction,
               .device = device_text(device)};
  plan.em_seconds =
      em_seconds(plan.em_iteration_seconds, plan.iterations, done == 0, device != nullptr);
  if (!plan.refines) return plan;
  GradientConfig gradient;
  set_refinement_bounds(config, gradient);
  gradient.device = device;
  plan.refinement_steps = gradient.steps;
  plan.refinement_max_steps = gradient.steps > 0 ? 0 : gradient.max_steps;
  plan.refinement_epochs = config.refinement_epochs;
  plan.refinement_seconds = config.refinement_seconds;
  plan.refinement = estimate_refinement(samples, start, config.em.threads, gradient);
  return plan;
}

// fit_model on a sample set of `tile`; `watch`, where given, is told the plan and the
// refinement's progress.
BtfModel fit_samples(const SampleSet& samples, const FitTile& tile, const FitConfig& config,
                     const EmCallback& progress, const FitState* resume,
                     const EmStateCallback& after_iteration, FitState* state, Clock::time_point t0,
                     const FitObserver* watch = nullptr,
                     std::optional<PredictionRefinement>* refined = nullptr) {
  check_supported_components(config, samples.size());
  ProductMixture mix =
      resume ? resume->mixture : initial_mixture(samples, config.components, config.seed);
  EmConfig em_config = config.em;
  if (!em_config.device) em_config.device = open_compute_device(config.device);
  // Every process of a distributed fit makes the plan, told or not: its timings are passes
  // over every process's samples, which each process must join.
  if (samples.processes || (watch && watch->planned)) {
    const FitPlan plan =
        plan_fit(samples, config, mix, resume ? resume->result.iterations : 0, em_config.device);
    if (watch && watch->planned) watch->planned(plan);
  }
  const EmResult em = fit_em(samples, mix, em_config, progress, resume ? &resume->result : nullptr,
                             after_iteration);
  if (state) *state = FitState{mix, em};
  if (em.interrupted) return BtfModel{};
  // The mixture refined for the prediction: L is then that of the parameters stored.
  double final_l = em.final_log_likelihood;
  if (config.objective == FitObjective::kPrediction) {
    GradientConfig gradient;
    set_refinement_bounds(config, gradient);
    gradient.seed = config.seed;
    gradient.device = em_config.device;
    if (watch) {
      gradient.progress = watch->refinement;
      gradient.planned = watch->refinement_planned;
    }
    gradient.stop = config.em.stop;
    const PredictionRefinement done =
        refine_for_prediction(samples, mix, config.em.threads, gradient);
    if (refined) *refined = done;
    // Stopped before it changed the parameters (no step, no colour refit kept): they are EM's,
    // whose L is known, and a Ctrl-C is not kept waiting for a pass over every sample.
    const bool left_as_em = done.stopped && done.steps == 0 && done.error_final == done.error_em;
    if (!left_as_em) final_l = mean_log_likelihood(samples, mix, config.em.threads);
  }
  BtfModel m = model_of(tile, samples, config, std::move(mix), em);
  m.settings.log_likelihood = final_l;
  m.settings.seconds = seconds_since(t0);
  return m;
}

}  // namespace

FitConfig mixture_config(std::size_t components, int iterations, std::uint64_t seed, int threads) {
  FitConfig config;
  if (components != 0) config.components = components;
  if (iterations != 0) config.em.max_iterations = iterations;
  config.seed = seed;
  config.em.threads = threads;
  config.objective = FitObjective::kPrediction;
  return config;
}

BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress,
                   const FitState* resume, const EmStateCallback& after_iteration, FitState* state,
                   const FitObserver* watch) {
  const auto t0 = Clock::now();
  return fit_samples(make_sample_set(btf), tile_of(btf), config, progress, resume, after_iteration,
                     state, t0, watch);
}

FitRequest resume_request(const fs::path& path) {
  FitCheckpoint k = load_checkpoint(path);
  FitRequest r;
  r.input = k.input;
  r.tile = k.tile;
  r.made_tile = k.made_from;
  r.config.components = k.components;
  r.config.seed = k.seed;
  r.config.em.max_iterations = k.max_iterations;
  r.config.em.epsilon = k.epsilon;
  r.precision = k.precision;
  r.output = k.output;
  r.checkpoint = path.string();
  const double before = k.state.result.seconds.empty() ? 0.0 : k.state.result.seconds.back();
  r.resume = FitResume{path.string(), std::move(k), false, before};
  return r;
}

namespace {

// The --refine-steps a model's provenance records (0: none, as many as the fit afforded).
int recorded_refine_steps(const Provenance& p) {
  for (const auto& [name, value] : p.fit.settings)
    if (name == "refine steps") return std::clamp(std::atoi(value.c_str()), 0, kMaxRefineSteps);
  return 0;
}

// The --refine-epochs a model's provenance records (0, the default, where none).
int recorded_refine_epochs(const Provenance& p) {
  for (const auto& [name, value] : p.fit.settings)
    if (name == "refine epochs") return std::clamp(std::atoi(value.c_str()), 0, kMaxRefineEpochs);
  return 0;
}

// The --refine-seconds a model's provenance records (0, the default, where none).
double recorded_refine_seconds(const Provenance& p) {
  for (const auto& [name, value] : p.fit.settings)
    if (name == "refine seconds")
      return std::clamp(std::atof(value.c_str()), 1.0, kMaxRefineSeconds);
  return 0.0;
}

}  // namespace

FitRequest continue_request(const fs::path& path, const std::string& input, int iterations,
                            const std::string& output) {
  const std::string name = path.string();
  const std::vector<std::uint8_t> bytes = read_whole_file(path, "model file");
  const ModelFileContents c = open_model_file(bytes, name);
  if (c.method != kMixtureMethod)
    throw Error(Error::Kind::kArgument,
                fmt::format("'{}' holds a '{}' model; only a Gaussian mixture's EM goes on "
                            "(`continue`): fit that method again with the settings you want",
                            name, c.method));
  BtfModel m = read_mixture_payload(c.payload, c.flags, name);
  const Provenance& p = c.provenance;
  if (!p.recorded || p.fit.iterations.size() != m.settings.iterations)
    throw Error(Error::Kind::kArgument,
                fmt::format("'{}' records no provenance (written by an older btfgmm), so its "
                            "fit cannot go on; fit again with `iterations` {}",
                            name, iterations));
  FitRequest r;
  r.input = input.empty() ? p.data.source.name : input;
  if (r.input.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("'{}' does not name the data it was fitted to; give the data as the "
                            "input",
                            name));
  r.tile = m.origin;
  for (const auto& [setting, value] : p.fit.settings)
    if (setting == kTileSetting) r.made_tile = value;
  r.config.components = m.settings.components;
  r.config.seed = m.settings.seed;
  r.config.em.max_iterations = iterations;
  r.config.em.epsilon = m.settings.epsilon;
  r.config.objective = recorded_objective(p);
  r.config.refinement_steps = recorded_refine_steps(p);
  r.config.refinement_seconds = recorded_refine_seconds(p);
  r.config.refinement_epochs = recorded_refine_epochs(p);
  r.precision = m.precision;
  r.output = output;
  FitCheckpoint k = checkpoint_of(r, Tile{}, 0);
  k.input = p.data.source.name;
  k.tile = m.origin;
  k.data_fingerprint = data_fingerprint(m.lights, m.views, m.width, m.height, p.data.content_hash);
  k.runs = p.fit.runs;
  EmResult& e = k.state.result;
  e.iterations = int(m.settings.iterations);
  e.dropped = m.settings.dropped;
  for (const IterationRecord& it : p.fit.iterations) {
    e.log_likelihood.push_back(it.log_likelihood);
    e.seconds.push_back(it.seconds);
    e.components.push_back(it.components);
  }
  k.state.mixture = std::move(m.mixture);
  r.resume = FitResume{name, std::move(k), true, p.fit.seconds};
  return r;
}

void set_refinement_bounds(const FitConfig& config, GradientConfig& gradient) {
  gradient.steps = config.refinement_steps;
  const bool chosen = config.refinement_seconds > 0 || config.refinement_epochs > 0;
  gradient.max_steps = chosen ? 0 : kDefaultRefineSteps;
  gradient.seconds = config.refinement_seconds > 0 ? config.refinement_seconds : kMaxRefineSeconds;
  gradient.max_epochs = config.refinement_epochs > 0 ? config.refinement_epochs : kMaxRefineEpochs;
}

FitOutcome fit_in_memory(const FitRequest& request, const FitObserver& observer) {
  const LoadedTile loaded = load_tile(request);
  const auto t0 = Clock::now();
  const FitTile& tile = loaded.tile;
  FitCheckpoint job = checkpoint_of(request, tile.origin,
                                    data_fingerprint(tile.lights, tile.views, tile.origin.width,
                                                     tile.origin.height, loaded.data.content_hash));
  if (request.resume) {
    check_resume(*request.resume, job);
    // A continued model's fit is another (from its rounded parameters); a resumed one's is the
    // same fit, and writes the same file as one never interrupted.
    job.runs = request.resume->checkpoint.runs + (request.resume->finished_model ? 1 : 0);
  }
  if (observer.started) observer.started(tile);
  FitState state;
  std::optional<PredictionRefinement> refined;
  BtfModel model = fit_samples(loaded.samples, tile, request.config, observer.iteration,
                               request.resume ? &request.resume->checkpoint.state : nullptr,
                               periodic_checkpoints(request, job), &state, t0, &observer, &refined);
  if (state.result.interrupted) return save_interrupted(request, job, std::move(state));
  record_provenance(request, job, loaded.data, model);
  if (refined) model.provenance.fit.settings.push_back(refinement_record(*refined));
  model.precision = request.precision;
  FitOutcome out;
  out.model = std::move(model);
  out.refinement = refined;
  // Stopped in the refinement: EM's final state is kept, for --resume to refine again.
  if (refined && refined->stopped) out.checkpoint = save_state(request, job, std::move(state));
  return out;
}

FitOutcome run_fit(const FitRequest& request, const FitObserver& observer) {
  FitOutcome out = fit_in_memory(request, observer);
  if (!out.interrupted) save_finished(request, out);
  return out;
}

}  // namespace btfgmm
