// The best model within a budget of file bytes; see budget.hpp.
#include "btfgmm/measure/budget.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <tuple>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/size_search.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/model_file.hpp"

namespace btfgmm {

namespace {

// A candidate's model with the choice's note in its provenance, and its file's bytes: what
// `fit --budget` writes, so that its size is the size compared with the budget.
struct NotedModel {
  std::shared_ptr<Representation> model;
  std::vector<std::uint8_t> file;
};

NotedModel with_note(const Representation& m, std::uint64_t budget, const BudgetRequest& r,
                     const std::string& name) {
  std::unique_ptr<Representation> copy = read_representation(representation_file_bytes(m), name);
  Provenance p = copy->provenance();
  std::erase_if(p.fit.settings, [](const auto& kv) { return kv.first == "chosen by"; });
  std::function<std::string(std::string_view)> spelling = r.option_spelling;
  if (!spelling) spelling = [](std::string_view field) { return std::string(field); };
  p.fit.settings.push_back({"chosen by", spell_options(budget_note(budget), spelling)});
  copy->set_provenance(std::move(p));
  NotedModel n;
  n.file = representation_file_bytes(*copy);
  n.model = std::move(copy);
  return n;
}

// One setting of `method` fitted and measured as run_sweep does (its file read back); none if
// the method refused it for the tile (recorded in `out`).
std::optional<ModelComparison> fit_setting(const Btf& tile, const BudgetRequest& r,
                                           const MethodInfo& method, const FitOptions& s,
                                           BudgetChoice& out) {
  SweepRequest q;
  q.source = r.source;
  q.methods = {std::string(method.name)};
  q.ladders[std::string(method.name)] = {s};
  q.options = r.options;
  for (const std::string_view f : r.given)  // those this method takes
    if (method_parameter(method, f)) q.given.push_back(f);
  q.progress = r.progress;
  q.stop = r.stop;
  SweepOutcome o = run_sweep(tile, q);
  if (o.stopped)
    throw Error(Error::Kind::kArgument, "fit `budget`: interrupted before a model was chosen");
  out.skipped.insert(out.skipped.end(), o.skipped.begin(), o.skipped.end());
  if (o.models.empty()) return std::nullopt;
  return std::move(o.models[0]);
}

std::vector<const MethodInfo*> budget_methods(const BudgetRequest& r) {
  std::vector<const MethodInfo*> out;
  if (r.methods.empty())
    for (const MethodInfo& m : all_methods()) out.push_back(&m);
  for (const std::string& name : r.methods) out.push_back(&find_method(name));
  return out;
}

// The one size (components, clusters, degree) in which two settings of a ladder differ, or
// null when none or several do (then no setting lies between them).
using SizeField = std::size_t FitOptions::*;
SizeField varying_size(const FitOptions& a, const FitOptions& b) {
  SizeField out = nullptr;
  for (SizeField f : {&FitOptions::components, &FitOptions::clusters, &FitOptions::degree})
    if (a.*f != b.*f) {
      if (out) return nullptr;
      out = f;
    }
  return out;
}

// A setting fitted: its file's bytes (with the choice's note), whether it fits.
struct Probe {
  FitOptions settings;
  std::uint64_t bytes = 0;
  bool fits = false;
};

// The search of one method's sizes: its ladder walked up from the smallest model while the
// file fits, then, between the largest rung that fits and the first that does not (or below
// the smallest rung, down to a size of 1; or above the largest, when it fits), the largest
// size whose file fits (size_search.hpp).
class MethodSearch {
 public:
  MethodSearch(const Btf& tile, const BudgetRequest& r, const MethodInfo& m, BudgetChoice& out)
      : tile_(tile), r_(r), m_(m), out_(out) {}

  // The smallest model's file fitted (what nothing_fits names), or null if none was.
  void run(std::shared_ptr<Representation>& smallest, std::uint64_t& smallest_bytes) {
    smallest_ = &smallest;
    smallest_bytes_ = &smallest_bytes;
    const std::vector<FitOptions> ladder = m_.ladder(ModelFrame::of(tile_));
    std::optional<Probe> below, fits, over;
    std::optional<FitOptions> refused;  // the first rung above `fits` the method refused
    std::size_t over_rung = 0;
    for (std::size_t k = 0; k < ladder.size() && !over; ++k) {
      const std::optional<Probe> p = fit(ladder[k]);
      if (synthesis_) return;
      if (!p) {
        if (fits && !refused) refused = ladder[k];
        continue;
      }
      if (p->fits) std::tie(below, fits) = std::pair(fits, p);
      if (!p->fits) over = p;
      over_rung = k;
    }
    if (!over && fits) return above(below, *fits, refused);
    if (!over) return;  // none could be fitted
    if (fits) return between(*fits, *over);
    // The smallest rung is over the budget: sizes below it, down to 1.
    if (over_rung + 1 >= ladder.size()) return;
    const SizeField f = varying_size(ladder[over_rung], ladder[over_rung + 1]);
    if (!f || over->settings.*f <= 1) return;
    FitOptions least = over->settings;
    least.*f = 1;
    if (const std::optional<Probe> p = fit(least); p && p->fits) between(*p, *over);
  }

 private:
  // Between a size that fits and a larger one that does not: the largest that fits.
  void between(const Probe& lo, const Probe& hi) {
    const SizeField f = varying_size(lo.settings, hi.settings);
    if (!f) return;
    largest_size_between(size_probe(lo, f), size_probe(hi, f), r_.budget, fit_size(lo.settings, f));
  }

  // Above the largest rung, which fits (largest_size_above). `refused`, a rung the method
  // refused, caps the sizes.
  void above(const std::optional<Probe>& below, const Probe& top,
             const std::optional<FitOptions>& refused) {
    const SizeField f = below ? varying_size(below->settings, top.settings)
                              : (refused ? varying_size(top.settings, *refused) : nullptr);
    if (!f) return;
    const std::size_t cap = refused ? (*refused).*f : std::numeric_limits<std::size_t>::max();
    std::optional<SizeProbe> under;
    if (below) under = size_probe(*below, f);
    largest_size_above(under, size_probe(top, f), cap, r_.budget, fit_size(top.settings, f));
  }

  static SizeProbe size_probe(const Probe& p, SizeField f) {
    return {.size = p.settings.*f, .bytes = p.bytes, .fits = p.fits};
  }

  // `base` with its size `f` set to each size asked, fitted.
  FitSize fit_size(const FitOptions& base, SizeField f) {
    return [this, base, f](std::size_t size) -> std::optional<SizeProbe> {
      FitOptions s = base;
      s.*f = size;
      const std::optional<Probe> p = fit(s);
      if (!p) return std::nullopt;
      return size_probe(*p, f);
    };
  }

  // One setting fitted, measured and recorded as a candidate (the best that fits kept).
  std::optional<Probe> fit(const FitOptions& s) {
    std::optional<ModelComparison> c = fit_setting(tile_, r_, m_, s, out_);
    if (!c) return std::nullopt;
    if (c->model->synthesises()) {
      out_.synthesis_methods.push_back(std::string(m_.name));
      synthesis_ = true;
      return std::nullopt;
    }
    NotedModel n = with_note(*c->model, r_.budget, r_, c->name);
    const Probe p{s, n.file.size(), n.file.size() <= r_.budget};
    out_.candidates.push_back({std::string(m_.name), settings_text(s), c->model->size_text(),
                               p.bytes, c->quality.psnr_db, p.fits});
    if (!*smallest_ || p.bytes < *smallest_bytes_) {
      *smallest_ = n.model;
      *smallest_bytes_ = p.bytes;
    }
    if (p.fits && (!out_.model || c->quality.psnr_db > out_.candidates[out_.chosen].psnr_db)) {
      out_.chosen = out_.candidates.size() - 1;
      out_.model = std::move(n.model);
      out_.file = std::move(n.file);
    }
    return p;
  }

  const Btf& tile_;
  const BudgetRequest& r_;
  const MethodInfo& m_;
  BudgetChoice& out_;
  std::shared_ptr<Representation>* smallest_ = nullptr;
  std::uint64_t* smallest_bytes_ = nullptr;
  bool synthesis_ = false;
};

// No candidate fits: the smallest file possible (`smallest`, with the note of that budget,
// whose digits count) and its method, or why none was fitted.
Error nothing_fits(const BudgetChoice& c, const BudgetRequest& r, const Representation* smallest) {
  const std::uint64_t budget = r.budget;
  if (c.candidates.empty() || !smallest)
    return Error(
        Error::Kind::kArgument,
        fmt::format("fit `budget` {}: no pixel-wise method could be fitted to this "
                    "tile{}; give a larger tile",
                    budget,
                    c.skipped.empty()
                        ? std::string()
                        : fmt::format(" (the first refused: {} {}: {})", c.skipped[0].method,
                                      c.skipped[0].settings, c.skipped[0].message)));
  std::uint64_t least = budget;
  for (int k = 0; k < 4; ++k) {
    const std::uint64_t bytes = with_note(*smallest, least, r, "the smallest").file.size();
    if (bytes == least) break;
    least = bytes;
  }
  return Error(Error::Kind::kArgument,
               fmt::format("fit `budget` {} bytes: no method's file fits; the smallest possible "
                           "for this tile is {} bytes ({} {}); give `budget` {} or more",
                           budget, least, smallest->method(), smallest->size_text(), least));
}

}  // namespace

std::string budget_note(std::uint64_t budget) {
  return fmt::format("`budget` {} bytes: the best PSNR of the candidates that fit", budget);
}

BudgetChoice choose_within_budget(const Btf& tile, const BudgetRequest& r) {
  if (r.budget == 0)
    throw Error(Error::Kind::kArgument, "fit `budget`: the budget must be at least 1 byte");
  const std::vector<const MethodInfo*> methods = budget_methods(r);
  BudgetChoice out;
  std::shared_ptr<Representation> smallest;  // the smallest file fitted
  std::uint64_t smallest_bytes = 0;
  for (const MethodInfo* m : methods) MethodSearch(tile, r, *m, out).run(smallest, smallest_bytes);
  if (!out.model) throw nothing_fits(out, r, smallest.get());
  return out;
}

}  // namespace btfgmm
