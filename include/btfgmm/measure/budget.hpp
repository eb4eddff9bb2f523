// The method and size that decode a tile best within a budget of true file bytes, each model
// stored as `fit` stores it by default (default_file_encoding). For each pixel-wise method, the
// largest size whose file fits (methods that synthesise texture are left out: no pixel-wise
// PSNR measures them). A method with a quick search (MethodInfo::quick_search: the Gaussian
// mixture and the neural BTF, whose fits take minutes) has its size at the budget predicted from
// the files of short fits (probes) and only that size fitted in full, its file brought within the
// budget by coarser steps where it is a few percent over (QuickSearch in budget.cpp). Every other
// method: its ladder of sizes (MethodInfo::ladder, as `sweep` fits it) walked from its smallest
// model up while the file fits, then the sizes between the last rung that fits and the first that
// does not (below the smallest rung: down to a size of 1; above the largest, when it fits: up
// to the first size over the budget or refused for the tile) searched by predicting a size's
// bytes from the two nearest fitted and confirming with the real file (size_search.hpp), every
// setting fitted and measured as run_sweep does, but for sizes whose bytes the line through
// two sizes fitted puts more than 5 % over the budget (not fitted, listed as not_fitted;
// `exhaustive` fits them). Then the candidate that fits with the highest
// PSNR on the tile is kept. `btfgmm fit --budget` and `--ratio` format what
// choose_within_budget returns.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

struct BudgetRequest {
  std::uint64_t budget = 0;          // true file bytes, at most
  DataSource source;                 // where the tile was read from (the model's provenance)
  std::vector<std::string> methods;  // by name; empty: every method
  // The options every candidate takes where its method takes them (`given`, by field, of
  // `options`: the seed, threads, iterations, the refinement's bounds), as
  // SweepRequest::options; checked first, once, by the front end (check_fit_options, route
  // kBudget: before any work).
  FitOptions options;
  std::vector<std::string_view> given;
  std::function<void(const SweepProgress&)> progress;  // each fit's, as run_sweep reports it
  const std::atomic<bool>* stop = nullptr;
  // Every method's sizes searched by full fits, as sweep fits them, also where the method has
  // a quick search (MethodInfo::quick_search): the slower search the quick one is measured
  // against.
  bool exhaustive = false;
  // How the chosen model's note spells the option it names (core/text.hpp, spell_options):
  // the front end's spelling; empty: the field's name.
  std::function<std::string(std::string_view field)> option_spelling;
};

// One setting fitted.
struct BudgetCandidate {
  std::string method, settings, size;  // settings_text, Representation::size_text
  std::uint64_t file_bytes = 0;        // the true file, the choice's note in its provenance
  double psnr_db = 0.0;                // on the tile
  bool fits = false;                   // file_bytes <= the budget
  // Its quantisation steps as a multiple of the method's own (MethodInfo::coarsened): above 1
  // for a quick search's choice stored with coarser steps to fit the budget.
  double step_factor = 1.0;
};

// A quick search's probe (QuickSizeSearch): a short fit whose file predicts a size's bytes.
struct BudgetProbe {
  std::string method, settings;  // the probe's settings
  std::uint64_t file_bytes = 0;  // its file's
  double predicted_bytes = 0.0;  // the full fit's, as the probe predicts them
};

// A size not fitted (but with `exhaustive`): the line through two sizes of its method fitted
// (`from` and `to`, their settings) puts its file well over the budget.
struct PredictedSize {
  std::string method, settings;
  double predicted_bytes = 0.0;
  std::string from, to;
};

struct BudgetChoice {
  std::vector<BudgetCandidate> candidates;  // every setting fitted, in the order fitted
  std::vector<BudgetProbe> probes;          // in the order fitted
  std::vector<PredictedSize> not_fitted;    // in the order predicted
  std::vector<SkippedSetting> skipped;      // settings a method refused for the tile
  // Methods left out: they synthesise new texture, which no pixel-wise PSNR measures.
  std::vector<std::string> synthesis_methods;
  std::size_t chosen = 0;                 // the index of the candidate kept
  std::shared_ptr<Representation> model;  // it, its provenance noting the choice
  std::vector<std::uint8_t> file;         // its model file's bytes (file_bytes of it)
};

// The note a chosen model's provenance carries (FitLog::settings): ("chosen by", this), the
// option it names marked (option_name) for the request's option_spelling.
std::string budget_note(std::uint64_t budget);

// Fits and measures the candidates and keeps the best that fits. Throws Error(kArgument) for
// a budget of 0, for an unknown method (the nearest name), and, when no method's smallest file
// fits, naming the smallest file possible (each method's smallest size fitted) and its method.
BudgetChoice choose_within_budget(const Btf& tile, const BudgetRequest& request);

}  // namespace btfgmm
