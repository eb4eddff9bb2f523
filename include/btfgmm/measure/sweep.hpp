// The rate-distortion sweep: every chosen method fitted to one tile at each size of its ladder
// (MethodInfo::ladder: compression ratios from about 1:5 to 1:500), each model's file bytes
// counted and the model measured against the tile (RMSE, PSNR, SSIM, decode time), and the
// Pareto front of quality against the true compression ratio marked. `btfgmm sweep` formats
// what run_sweep returns; the report (report/report.hpp) draws it.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {

// What a sweep tells its caller as it goes.
struct SweepProgress {
  enum class Event {
    kStart,    // a setting's fit begins
    kFit,      // the method's own progress within the fit (fraction, stage)
    kMeasure,  // the model is fitted: its file bytes counted, the tile decoded and measured
    kDone,     // the setting is measured: `result`
    kSkipped,  // the method refused the setting: `message`
  };
  Event event = Event::kStart;
  std::string_view method;
  std::size_t index = 0, count = 0;  // the setting under way (0-based) of all the sweep's
  std::string_view settings;         // "components 30" (settings_text)
  double fraction = 0.0;             // kFit: of the setting's fit, 0..1
  std::string_view stage;            // kFit: what the method is doing
  double elapsed_seconds = 0.0;      // since the sweep began
  // Of the whole sweep: the settings done (fitted or skipped) and, once one is done, the time
  // the rest should take at the mean pace so far (NaN before).
  std::size_t done = 0;
  double remaining_seconds = 0.0;
  const ModelComparison* result = nullptr;  // kDone
  std::string_view message;                 // kSkipped
};

struct SweepRequest {
  DataSource source;                 // where the tile was read from (the models' provenance)
  std::vector<std::string> methods;  // by name, in the order to fit; empty: every method
  // Settings fitted instead of a method's ladder, by method name (each a method swept).
  std::map<std::string, std::vector<FitOptions>, std::less<>> ladders;
  // The options set on every setting of the methods that take them (a ladder's own values
  // replaced): the fields `given` (by field) of `options`: `precision` (unset: the file `fit`
  // writes by default, default_file_encoding), `seed`, `threads`, `iterations` (the methods
  // that iterate; the others fit as usual and are named in SweepOutcome::not_iterated), the
  // refinement's bounds (gm; given with gm not swept, Error(kArgument)).
  FitOptions options;
  std::vector<std::string_view> given;
  // Not empty: each model's file is also written there (created if needed), named
  // ModelComparison::name + ".btfgmm".
  std::filesystem::path model_folder;
  CompareOptions compare;  // the pictured pairs and SSIM of each comparison
  std::function<void(const SweepProgress&)> progress;
  const std::atomic<bool>* stop = nullptr;  // set: the sweep ends after the fit under way
};

// A setting the method refused (Error(kArgument) from its fit, e.g. more components than the
// tile has images): recorded, not fatal.
struct SkippedSetting {
  std::string method;
  std::string settings;  // settings_text
  std::string message;   // the method's error
};

struct SweepOutcome {
  // Method by method in the request's order, each in its ladder's order. Each with
  // fit_seconds, file_bytes (the true size of its model file), decode_seconds and its quality,
  // measured on the model as read back from its file's bytes (what `compare` of the file
  // gives); named "<method>-<size>" (e.g. "gm-M30", "lpca-k8-c4").
  std::vector<ModelComparison> models;
  std::vector<std::string> settings;  // models[i]'s setting (settings_text)
  std::vector<bool> pareto;           // models[i] is on the Pareto front (pareto_front)
  std::vector<SkippedSetting> skipped;
  std::vector<std::string> not_iterated;  // methods swept that take no `iterations` (asked)
  std::size_t total = 0;                  // the sweep's settings (fitted, skipped or not reached)
  bool stopped = false;                   // the stop flag ended the sweep early
};

// Fits every setting of the request to `tile` and measures it. The request's options are
// checked first, once, by its front end (check_fit_options, route kSweep: before any work).
// Throws Error(kArgument) for an unknown method (with the nearest name), a method named twice,
// a ladder for a method not swept, or refinement bounds with no method swept that refines; an
// empty ladder (override) fits nothing for that method. Errors other than a refused setting
// (kIo writing a model file, ...) end the sweep.
SweepOutcome run_sweep(const Btf& tile, const SweepRequest& request);

// The settings that set a model's size, for messages: "components 30", "clusters 8,
// components 4", "degree 4"; "the method's defaults" when none is set.
std::string settings_text(const FitOptions& s);

// The Pareto front of (compression ratio, PSNR) points: point i is on it when no other point
// has a ratio at least as high and a PSNR at least as high, one of them strictly (the highest
// PSNR for its ratio or any larger). Equal points are all on it; a point with a NaN is not.
std::vector<bool> pareto_front(std::span<const std::array<double, 2>> ratio_psnr);
// The same over models by the ratio of their file bytes (Representation::file_ratio) and
// their PSNR; a model without file bytes (0) is not on it, nor one that synthesises new
// texture (Representation::synthesises: its pixel-wise PSNR measures nothing).
std::vector<bool> pareto_front(std::span<const ModelComparison> models);

}  // namespace btfgmm
