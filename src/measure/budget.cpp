// The best model within a budget of file bytes; see budget.hpp.
#include "btfgmm/measure/budget.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/measure/size_search.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/prediction_device.hpp"
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

Error interrupted() {
  return Error(Error::Kind::kArgument, "fit `budget`: interrupted before a model was chosen");
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
  if (o.stopped) throw interrupted();
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

// The one size (components, clusters, degree; the network's width and depth) in which two
// settings of a ladder differ, or null when none or several do (then no setting lies between
// them).
using SizeField = std::size_t FitOptions::*;
SizeField varying_size(const FitOptions& a, const FitOptions& b) {
  SizeField out = nullptr;
  for (SizeField f : {&FitOptions::components, &FitOptions::clusters, &FitOptions::degree,
                      &FitOptions::width, &FitOptions::depth})
    if (a.*f != b.*f) {
      if (out) return nullptr;
      out = f;
    }
  return out;
}

// The candidates fitted so far: each recorded with its file's bytes (the choice's note in its
// provenance), the best that fits kept, and the smallest file (what nothing_fits names).
class Candidates {
 public:
  explicit Candidates(const BudgetRequest& r) : r_(r) {}
  BudgetChoice choice;
  std::shared_ptr<Representation> smallest;
  std::uint64_t smallest_bytes = 0;

  // Records a measured model as `settings` of `method`; returns its file's bytes.
  std::uint64_t record(const MethodInfo& method, std::string settings, const ModelComparison& c,
                       double step_factor = 1.0) {
    NotedModel n = with_note(*c.model, r_.budget, r_, c.name);
    const std::uint64_t bytes = n.file.size();
    const bool fits = bytes <= r_.budget;
    choice.candidates.push_back({std::string(method.name), std::move(settings),
                                 c.model->size_text(), bytes, c.quality.psnr_db, fits,
                                 step_factor});
    if (!smallest || bytes < smallest_bytes) {
      smallest = n.model;
      smallest_bytes = bytes;
    }
    if (fits && (!choice.model || c.quality.psnr_db > choice.candidates[choice.chosen].psnr_db)) {
      choice.chosen = choice.candidates.size() - 1;
      choice.model = std::move(n.model);
      choice.file = std::move(n.file);
    }
    return bytes;
  }

 private:
  const BudgetRequest& r_;
};

// A setting fitted: its file's bytes (with the choice's note), whether it fits.
struct Probe {
  FitOptions settings;
  std::uint64_t bytes = 0;
  bool fits = false;
};

// A file's bytes are linear in its method's size to within about 3 % (measured on generated
// knit 25 x 25: PCA BTF's c = 13 and 18 and LPCA's k = 5 and 8 against the line through the
// two sizes fitted below them). So a size whose bytes the line through two sizes fitted puts
// more than this fraction over the budget is over it, and (but with --exhaustive) not fitted.
constexpr double kPredictedOverMargin = 0.05;

// The bytes the line through `a` and `b` (fitted, of different sizes in `f`) puts at `s`.
double bytes_on_line(const Probe& a, const Probe& b, SizeField f, const FitOptions& s) {
  const double slope =
      (double(b.bytes) - double(a.bytes)) / (double(b.settings.*f) - double(a.settings.*f));
  return double(b.bytes) + slope * (double(s.*f) - double(b.settings.*f));
}

// The search of one method's sizes: its ladder walked up from the smallest model while the
// file fits, then, between the largest rung that fits and the first that does not (or below
// the smallest rung, down to a size of 1; or above the largest, when it fits), the largest
// size whose file fits (size_search.hpp). Sizes whose files the line through two fitted sizes
// puts well over the budget (kPredictedOverMargin) are not fitted, but with --exhaustive.
class MethodSearch {
 public:
  MethodSearch(const Btf& tile, const BudgetRequest& r, const MethodInfo& m, Candidates& out)
      : tile_(tile), r_(r), m_(m), out_(out) {}

  void run() {
    const std::vector<FitOptions> ladder = m_.ladder(ModelFrame::of(tile_));
    std::optional<Probe> below, fits, over;
    std::optional<FitOptions> refused;  // the first rung above `fits` the method refused
    std::size_t over_rung = 0;
    for (std::size_t k = 0; k < ladder.size() && !over; ++k) {
      if (below && fits && (over = predicted_over(*below, *fits, ladder[k]))) break;
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
  // Between a size that fits and a larger one that does not: the largest that fits; none
  // when the next size above `lo` is predicted well over the budget.
  void between(const Probe& lo, const Probe& hi) {
    const SizeField f = varying_size(lo.settings, hi.settings);
    if (!f) return;
    if (FitOptions next = lo.settings; hi.settings.*f - lo.settings.*f > 1) {
      next.*f += 1;
      if (predicted_over(lo, hi, next)) return;
    }
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

  // `s`, not fitted, when the line through `a` and `b` (sizes fitted, or `b` a size this
  // predicted on their line; differing in the size `s` differs from `b` in) puts its file
  // more than kPredictedOverMargin over the budget:
  // recorded with the bytes predicted. None with --exhaustive or otherwise.
  std::optional<Probe> predicted_over(const Probe& a, const Probe& b, const FitOptions& s) {
    const SizeField f = varying_size(a.settings, b.settings);
    if (r_.exhaustive || !f || f != varying_size(b.settings, s) || b.bytes <= a.bytes)
      return std::nullopt;
    const double bytes = bytes_on_line(a, b, f, s);
    if (!(bytes > double(r_.budget) * (1.0 + kPredictedOverMargin))) return std::nullopt;
    out_.choice.not_fitted.push_back({std::string(m_.name), settings_text(s), bytes,
                                      settings_text(a.settings), settings_text(b.settings)});
    return Probe{s, std::uint64_t(std::ceil(bytes)), false};
  }

  // One setting fitted, measured and recorded as a candidate (the best that fits kept).
  std::optional<Probe> fit(const FitOptions& s) {
    std::optional<ModelComparison> c = fit_setting(tile_, r_, m_, s, out_.choice);
    if (!c) return std::nullopt;
    if (c->model->synthesises()) {
      out_.choice.synthesis_methods.push_back(std::string(m_.name));
      synthesis_ = true;
      return std::nullopt;
    }
    const std::uint64_t bytes = out_.record(m_, settings_text(s), *c);
    return Probe{s, bytes, bytes <= r_.budget};
  }

  const Btf& tile_;
  const BudgetRequest& r_;
  const MethodInfo& m_;
  Candidates& out_;
  bool synthesis_ = false;
};

// ---- The quick search (MethodInfo::quick_search) ------------------------------------------

// A size and the bytes of its full fit's file, as a probe's file predicts them.
struct PredictedBytes {
  std::size_t size = 0;
  double bytes = 0.0;
};

// The size the line through `a` and `b` puts at `budget` bytes, at least 1; `b`'s size when
// the bytes do not grow with the size.
std::size_t size_on_line(const PredictedBytes& a, const PredictedBytes& b, double budget) {
  const double slope = (b.bytes - a.bytes) / (double(b.size) - double(a.size));
  if (!(slope > 0.0)) return b.size;
  const double size = double(a.size) + (budget - a.bytes) / slope;
  return std::size_t(std::clamp(std::floor(size), 1.0, 1e12));
}

// The coarser steps tried, in turn, on a chosen model whose file is over the budget: 2^(k/4)
// times the default's for k = 1..8 (a file some 11 % smaller at 4 times, the PSNR 0.02 dB
// lower on generated knit: docs/BENCHMARKS.md).
constexpr int kCoarserSteps = 8;
double coarser_factor(int k) {
  return std::exp2(double(k) / 4.0);
}

// A method's size at the budget predicted from probes (QuickSizeSearch): the ladder's largest
// rung probed; when its predicted file fits, twice that size (or the size parameter's most)
// and the line through the two; else the rungs below, down to the first that fits, and the
// line through it and the rung above. Only the size predicted is fitted in full (as the
// search fits its choice, QuickSizeSearch::choice); a file over the budget by a few percent is
// stored with coarser steps (MethodInfo::coarsened) until it fits, and one over by more is
// fitted once more at the size the bytes' slope puts at the budget.
class QuickSearch {
 public:
  QuickSearch(const Btf& tile, const BudgetRequest& r, const MethodInfo& m, Candidates& out,
              const DataFingerprint& data)
      : tile_(tile), r_(r), m_(m), out_(out), data_(data) {}

  // False when the method's ladder has no size to search (then MethodSearch runs). The ladder
  // is searched in segments from the top: rungs next to each other that differ in the same one
  // size (a neural BTF's latent, then its width below). Where the budget lies below a
  // segment's rungs, the segment below it, whose top rung is that segment's first, is searched.
  bool run() {
    const std::vector<FitOptions> ladder = m_.ladder(ModelFrame::of(tile_));
    for (std::size_t end = ladder.size(); end >= 2;) {
      const std::vector<FitOptions> segment(ladder.begin(), ladder.begin() + std::ptrdiff_t(end));
      field_ = varying_size(segment[end - 2], segment[end - 1]);
      if (!field_) return false;
      base_ = segment.back();
      first_ = end - 2;
      while (first_ > 0 && varying_size(ladder[first_ - 1], ladder[first_]) == field_) --first_;
      below_ = false;
      slope_ = 0.0;
      if (const std::size_t size = predicted_size(segment); size > 0) {
        choose(size, true);
        return true;
      }
      if (!below_) return false;
      end = first_ + 1;
    }
    return false;
  }

 private:
  // The size whose full fit's file the probes put at the budget; 0 when the method refused
  // every size probed, or when the budget is below the top rungs that differ in the size alone
  // (first_) and rungs below them differ in another (below_). The largest rung the method accepts
  // is probed first: a budget above it needs no other rung. Below it, the rungs from first_ are
  // walked up (the cheapest probes first) to the first over the budget.
  std::size_t predicted_size(const std::vector<FitOptions>& ladder) {
    const double budget = double(r_.budget);
    std::size_t cap = largest_size();  // refused above (the tile's samples, the house's most)
    std::size_t top = ladder.size();
    std::optional<PredictedBytes> at_top;
    while (top-- > 0) {
      if (ladder[top].*field_ > cap) continue;
      if ((at_top = probe(ladder[top].*field_))) break;
      cap = ladder[top].*field_ - 1;  // refused for the tile, as every larger size is
    }
    if (!at_top) return 0;
    if (at_top->bytes <= budget)
      return size_above(*at_top, top > 0 ? ladder[top - 1].*field_ : 0, cap);
    std::optional<PredictedBytes> fits;
    for (std::size_t k = std::min(first_, top); k <= top; ++k) {
      const std::optional<PredictedBytes> p = k == top ? at_top : probe(ladder[k].*field_);
      if (!p) return fits ? fits->size : 0;
      if (p->bytes <= budget) {
        fits = p;
        continue;
      }
      if (fits) return std::min(line_size(*fits, *p), p->size - 1);
      // The smallest rung of this size over, below it rungs that differ in another: none
      // predicted here (the segment below is searched).
      if (k > 0) {
        below_ = true;
        return 0;
      }
      // The smallest rung is over: the line through it and the next, below it.
      const std::optional<PredictedBytes> next =
          k + 1 == top ? at_top : (k + 1 < top ? probe(ladder[k + 1].*field_) : std::nullopt);
      return next ? std::min(line_size(*p, *next), p->size - 1)
                  : std::min<std::size_t>(1, p->size - 1);
    }
    return fits ? fits->size : 0;
  }

  // Above `fits`, the largest rung accepted, whose file fits (`below`: the rung under it, 0
  // if none): the line through it and twice its size (or through the rung below, where twice
  // is refused), at most `cap`.
  std::size_t size_above(const PredictedBytes& fits, std::size_t below, std::size_t cap) {
    if (fits.size >= cap) return fits.size;
    const std::size_t far_size = std::min(2 * fits.size, cap);
    if (const std::optional<PredictedBytes> far = probe(far_size))
      return std::clamp(line_size(fits, *far), fits.size,
                        far->bytes > double(r_.budget) ? far_size - 1 : cap);
    cap = far_size - 1;
    if (below == 0) return fits.size;
    const std::optional<PredictedBytes> under = probe(below);
    if (!under) return fits.size;
    return std::clamp(line_size(*under, fits), fits.size, cap);
  }

  // size_on_line at the budget; the line's slope kept for a refit (choose).
  std::size_t line_size(const PredictedBytes& a, const PredictedBytes& b) {
    slope_ = (b.bytes - a.bytes) / (double(b.size) - double(a.size));
    return size_on_line(a, b, double(r_.budget));
  }

  // The most the method's size parameter takes, and its choice takes on this tile.
  std::size_t largest_size() const {
    std::size_t most = std::numeric_limits<std::size_t>::max() / 4;
    if (m_.quick_search.most_size)
      most = std::min(most, m_.quick_search.most_size(
                                ModelFrame::of(tile_),
                                m_.quick_search.choice(setting(base_.*field_), r_.given)));
    for (const FitParameter& p : m_.parameters)
      if (const auto* member = std::get_if<std::size_t FitOptions::*>(&p.member);
          member && *member == field_)
        return std::size_t(std::min(p.max, double(most)));
    return most;
  }

  // A probe of `size`, fitted (not measured) once: the bytes its file predicts for the full
  // fit; none where the method refuses the size for the tile (recorded as skipped). A setting
  // is probed once.
  std::optional<PredictedBytes> probe(std::size_t size) {
    const std::string key = settings_text(setting(size));
    if (const auto at = probed_.find(key); at != probed_.end()) {
      if (!at->second) return std::nullopt;
      return PredictedBytes{size, *at->second};
    }
    const std::optional<PredictedBytes> p = fitted_probe(size);
    probed_[key] = p ? std::optional<double>(p->bytes) : std::nullopt;
    return p;
  }

  std::optional<PredictedBytes> fitted_probe(std::size_t size) {
    FitOptions s = setting(size);
    s = m_.quick_search.probe(s);
    report_probe(s);
    std::unique_ptr<Representation> model;
    try {
      model = fit_and_record(m_, tile_, s, data_);
    } catch (const Error& e) {
      if (r_.stop && r_.stop->load()) throw interrupted();
      if (e.kind() != Error::Kind::kArgument) throw;
      out_.choice.skipped.push_back({std::string(m_.name), settings_text(s), e.what()});
      return std::nullopt;
    }
    if (r_.stop && r_.stop->load()) throw interrupted();
    const NotedModel noted = with_note(*model, r_.budget, r_, "probe");
    const double bytes = double(noted.file.size());
    const double fixed =
        double(representation_file_bytes(*m_.quick_search.without_size(*noted.model)).size());
    const PredictedBytes p{size, fixed + (bytes - fixed) * m_.quick_search.bytes_ratio};
    out_.choice.probes.push_back(
        {std::string(m_.name), settings_text(s), noted.file.size(), p.bytes});
    return p;
  }

  void report_probe(const FitOptions& s) const {
    if (!r_.progress) return;
    SweepProgress p;
    p.event = SweepProgress::Event::kStart;
    p.method = m_.name;
    const std::string text = settings_text(s) + " (a probe of the file's bytes)";
    p.settings = text;
    r_.progress(p);
  }

  // The options of a fit of `size`: the request's, where the method takes them.
  FitOptions setting(std::size_t size) const {
    FitOptions s = base_;
    s.*field_ = size;
    s.method = m_.name;
    for (const std::string_view f : r_.given)
      if (const FitParameter* p = method_parameter(m_, f)) copy_parameter(r_.options, s, *p);
    if (!s.precision) s.precision = default_file_encoding(m_);
    s.stop = r_.stop;
    return s;
  }

  // `size` fitted in full and measured; over the budget, stored with coarser steps, or (when
  // `again`) fitted once more at a smaller size.
  void choose(std::size_t size, bool again) {
    const FitOptions s = m_.quick_search.choice(setting(size), r_.given);
    std::optional<ModelComparison> c = fit_setting(tile_, r_, m_, s, out_.choice);
    if (!c) return;
    const std::uint64_t bytes = out_.record(m_, settings_text(s), *c);
    if (bytes <= r_.budget || (m_.coarsened && fits_coarser(*c, s))) return;
    if (!again || size <= 1) return;
    // The bytes over, at the slope the probes measured per size, below this size.
    const double slope = slope_ > 0.0 ? slope_ : double(bytes) / double(size);
    const double over = double(bytes - r_.budget);
    choose(size - std::min(size - 1, std::size_t(std::ceil(over / slope)) + 1), false);
  }

  // The chosen model stored with coarser steps, until its file fits; whether one did.
  bool fits_coarser(const ModelComparison& c, const FitOptions& s) {
    for (int k = 1; k <= kCoarserSteps; ++k) {
      const double factor = coarser_factor(k);
      std::shared_ptr<Representation> coarse = m_.coarsened(*c.model, factor);
      const std::vector<std::uint8_t> file = with_note(*coarse, r_.budget, r_, c.name).file;
      if (file.size() > r_.budget) continue;
      std::unique_ptr<Representation> read = read_representation(file, c.name);
      compute_where_fitted(*read, s);
      ModelComparison measured = compare_model(tile_, std::move(read), c.name, file.size());
      out_.record(m_, settings_text(s), measured, factor);
      return true;
    }
    return false;
  }

  const Btf& tile_;
  const BudgetRequest& r_;
  const MethodInfo& m_;
  Candidates& out_;
  const DataFingerprint& data_;
  SizeField field_ = nullptr;
  FitOptions base_;
  double slope_ = 0.0;
  // The predicted bytes of each setting probed (by its settings' text: a rung where two
  // segments meet is probed once); none where the method refused it.
  std::map<std::string, std::optional<double>> probed_;
  std::size_t first_ = 0;  // the first rung of the segment's, which differ in field_ alone
  bool below_ = false;     // the budget lies below the segment's rungs
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
  Candidates out(r);
  const DataFingerprint data = fingerprint_of(tile, r.source);
  for (const MethodInfo* m : methods) {
    if (m->synthesises) {
      out.choice.synthesis_methods.push_back(std::string(m->name));
      continue;
    }
    if (m->quick_search.probe && !r.exhaustive && QuickSearch(tile, r, *m, out, data).run())
      continue;
    MethodSearch(tile, r, *m, out).run();
  }
  if (!out.choice.model) throw nothing_fits(out.choice, r, out.smallest.get());
  return std::move(out.choice);
}

}  // namespace btfgmm
