// A fit from a BTF tile to a model: mean BRDF, samples, initialisation and EM (fit_model), and
// the whole job of `btfgmm fit` (run_fit): load the tile, fit, keep a checkpoint, write the
// model; interrupted, continue it from its checkpoint (resume_request).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/communicator.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/refine.hpp"

namespace btfgmm {

struct FitConfig {
  std::size_t components = 600;
  std::uint64_t seed = 1;
  EmConfig em;
  // kLikelihood: the paper's EM alone; kPrediction: EM, then the mixture refined for the
  // prediction's error (refine_for_prediction, model/refine.hpp; em.stop ends its steps
  // early). `btfgmm fit` asks for the latter unless --objective likelihood.
  FitObjective objective = FitObjective::kLikelihood;
  // kPrediction: the refinement's bounds (set_refinement_bounds). By default, at most
  // kDefaultRefineSteps Adam steps, ended sooner by its stopping rule: bounded in work, the fit
  // gives the same model at any load and with any thread count. refinement_steps: exactly
  // that many steps (the rule off). refinement_epochs, refinement_seconds: at most that many
  // epochs, seconds, in place of the default bound; a bound in seconds makes the model depend
  // on the machine and its load (its provenance says so).
  int refinement_steps = 0;
  double refinement_seconds = 0.0;
  int refinement_epochs = 0;
  // Where EM's E pass runs (gpu/compute_device.hpp, docs/GPU.md): kAuto, a hardware GPU where
  // one exists, else the CPU. The fit opens the device; em.device, where set, is used as is.
  DeviceChoice device = DeviceChoice::kAuto;
};

// The mixture's fit of `components` components and `iterations` EM iterations (0: the
// defaults above, M = 600 and EmConfig's 40) from `seed` on `threads` (0: OpenMP's default),
// with the prediction objective (the best, docs/ALGORITHM.md) and as many refinement steps as
// it affords. The one place every fit of the mixture (the command's, Python's, sweep's) takes
// its settings from.
FitConfig mixture_config(std::size_t components, int iterations, std::uint64_t seed, int threads);

// Mean BRDF, samples, initialisation and EM on a BTF tile. With `resume`, EM continues from
// that state instead of a fresh initialisation (the same tile and settings are the caller's
// to check: run_fit does). `after_iteration` as for fit_em. If the fit was interrupted
// (config.em.stop) during EM, *state receives where it stands and the returned model is
// empty; during the refinement for the prediction, its steps end there and the model holds
// the lowest error met. The
// model's provenance holds the fit's log (its EM iterations, this run's time); the data's
// fingerprint, the settings and `recorded` are the caller's to set (run_fit, fit_and_record).
// `watch`, where given, is told the plan and the refinement's progress (FitObserver).
struct FitObserver;
BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress = {},
                   const FitState* resume = nullptr, const EmStateCallback& after_iteration = {},
                   FitState* state = nullptr, const FitObserver* watch = nullptr);

// ---- The fit job: from a BTF on disk to a model file, interruptible and resumable --------

// A fit to go on with: an interrupted one (its checkpoint file and what that holds), or a
// finished mixture's (its model file, and a checkpoint made of it: continue_request).
struct FitResume {
  std::string path;
  FitCheckpoint checkpoint;
  bool finished_model = false;  // `path` is a model file, not a checkpoint
  // The fit's time before this run: a checkpoint's EM time, a model's whole fit time.
  double seconds_before = 0.0;
};

struct FitRequest {
  std::string input;  // a BTF folder or Bonn .zip
  Tile tile;          // the tile to fit (pixels); empty: the whole image
  // `input` already opened by the caller (e.g. to search it for a seamless tile,
  // measure/tile_option.hpp); null: run_fit opens it.
  std::shared_ptr<const BtfSource> source;
  // A resumed or continued fit of a made tile: its description (Btf::made_from), from the
  // checkpoint or the model's provenance; the caller makes `source` the tile made again
  // (measure/tile_option.hpp, fitted_source), as a new fit's caller does.
  std::string made_tile;
  FitConfig config;  // components, seed; EM's iterations, epsilon, threads and stop flag
  Precision precision = Precision::kF32;  // of the parameters in the model file
  std::string output;                     // the model file, written atomically
  // The fit's state is saved here (atomically) every `checkpoint_every` iterations; empty:
  // only when the fit is interrupted, then to output + ".ckpt". Removed once the model is
  // written.
  std::string checkpoint;
  int checkpoint_every = 1;
  // The processes of a fit over several (an MPI job; core/communicator.hpp): each reads and
  // fits its share of the lights, process 0 writes the checkpoints and the model, and the
  // model is that of a fit in one process, bit for bit. Null: this process alone.
  std::shared_ptr<Communicator> processes;
  // Continue this fit (see resume_request, continue_request); the tile, M, seed and
  // precision above must be the checkpoint's, the data the same, and the iterations at least
  // those already run (more go on to that many; epsilon may change).
  std::optional<FitResume> resume;
};

// The request that continues the fit whose checkpoint is `path`: its input, tile, settings
// and output, and its state; the state keeps being saved to `path`. Threads and the stop
// flag are the caller's to set. Throws as load_checkpoint.
FitRequest resume_request(const std::filesystem::path& path);

// The request that continues the finished mixture in the model file `path` to `iterations`
// EM iterations in all, from its stored parameters, on `input` (empty: the source its
// provenance records), writing `output`. The stored parameters are the fit's rounded to the
// file's precision, so the result equals one longer fit within that rounding, not bit for
// bit (docs/FORMAT.md). Throws Error(kFormat) as load_model, Error(kArgument) for a model of
// another method, one without provenance, or `iterations` not above those it has run.
FitRequest continue_request(const std::filesystem::path& path, const std::string& input,
                            int iterations, const std::string& output);

// The tile a fit holds, without its values.
struct FitTile {
  DirectionSet lights, views;
  Tile origin;  // where it was cut from its images (x, y, width, height)
  SampleFormat format = SampleFormat::kLdr8;
  std::size_t samples() const {
    return lights.size() * views.size() * std::size_t(origin.width) * std::size_t(origin.height);
  }
};

// What a fit will take, stated before EM: its iterations left, each timed on a few lights
// from the mixture EM starts from (estimate_em_iteration_seconds), and the refinement's bounds
// with its time estimated on that mixture (estimate_refinement; the estimate before the
// refinement, FitObserver::refinement_planned, is timed on EM's result).
struct FitPlan {
  std::size_t components = 0;
  int iterations = 0;                 // EM iterations at most, those a resume has run aside
  double em_iteration_seconds = 0.0;  // about, the first's
  double em_seconds = 0.0;            // about, every iteration's (later ones take less)
  bool refines = false;               // the objective kPrediction
  int refinement_steps = 0;           // exactly (FitConfig::refinement_steps), or 0
  int refinement_max_steps = 0;       // at most (the default bound), or 0
  int refinement_epochs = 0;          // at most, where the fit asked for a bound in epochs
  double refinement_seconds = 0.0;    // at most, where the fit asked for a bound in time
  RefinementEstimate refinement{};    // about, timed before EM
  std::string device;                 // where EM runs: "cpu" or the GPU's description
};

// The refinement's bounds in `gradient` as the fit's settings ask (FitConfig): exactly
// refinement_steps steps where given; at most refinement_epochs epochs and
// refinement_seconds seconds where either is given; otherwise at most kDefaultRefineSteps.
void set_refinement_bounds(const FitConfig& config, GradientConfig& gradient);

// What run_fit tells as it goes (the library prints nothing).
struct FitObserver {
  // The tile is in memory (for a resume: the very data of the checkpoint); EM starts next.
  std::function<void(const FitTile& tile)> started;
  // Then, where given, what the fit will take (its EM iteration timed on a few lights first).
  std::function<void(const FitPlan& plan)> planned;
  EmCallback iteration;  // after every EM iteration, as fit_em's progress
  // The fit for the prediction: before it starts, what it will take, timed on EM's mixture;
  // then after every validation (refine_for_prediction).
  std::function<void(const RefinementEstimate&)> refinement_planned;
  GradientCallback refinement;
};

struct FitOutcome {
  // Stopped by config.em.stop after `iterations` iterations: the state is in `checkpoint`,
  // and resume_request(checkpoint) continues the fit.
  bool interrupted = false;
  int iterations = 0;
  std::string checkpoint;
  // Otherwise the model written to the request's output (its provenance: the data's
  // fingerprint and the whole fit's log), and that file's size in bytes.
  BtfModel model;
  std::uint64_t file_bytes = 0;
  // With the objective kPrediction, what the refinement did: its steps and errors, and
  // whether config.em.stop ended it early (the model then holds the lowest error met, and is
  // written as any finished fit's; EM's final state is then saved to `checkpoint` as an
  // interrupted fit's would be, kept, and resume_request(checkpoint) refines again without
  // EM). Recorded in the provenance's settings as "refinement".
  std::optional<PredictionRefinement> refinement;
};

// run_fit but for the model file: the finished model (its provenance recorded, its precision
// the request's) is returned in memory (file_bytes 0) and the request's output is not
// written; a checkpoint is kept as run_fit keeps it (interrupted without a checkpoint or an
// output, the state is saved nowhere and the outcome's checkpoint is empty).
FitOutcome fit_in_memory(const FitRequest& request, const FitObserver& observer = {});

// With request.processes, every process calls run_fit with the same request; only process 0
// writes files (its outcome names them; the others' model is the same, file_bytes 0).
// Loads the request's tile, checks a resume against it (Error(kArgument) when the data or
// the settings are not the checkpoint's or the model's), fits (fit_model) with checkpoints as
// requested, and writes the model, or on an interruption the checkpoint. Throws Error as the
// loading, the fit and the writing do.
FitOutcome run_fit(const FitRequest& request, const FitObserver& observer = {});

}  // namespace btfgmm
