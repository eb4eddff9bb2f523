// btfgmm fit --budget / --ratio: see budget_fit.hpp.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/measure/budget.hpp"
#include "budget_fit.hpp"
#include "cli_util.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

std::string db_text(double v) {
  return std::isfinite(v) ? fmt::format("{:.2f}", v) : std::string("inf");
}

// The bytes a --ratio R asks for: the tile's data, a byte a value, over R.
std::uint64_t budget_bytes(const FitArguments& o, const Btf& tile) {
  if (o.budget > 0) return o.budget;
  const double raw = ModelFrame::of(tile).data_values();
  return std::uint64_t(std::floor(raw / o.ratio));
}

// "M = 1984", with ", steps x1.19" where the file was stored with coarser steps.
std::string size_text(const BudgetCandidate& b) {
  if (b.step_factor == 1.0) return b.size;
  return fmt::format("{}, steps x{:.2f}", b.size, b.step_factor);
}

// The candidates tried, on stderr: method, size, true file bytes, PSNR, the one chosen; then
// the quick searches' probes.
void print_candidates(const BudgetChoice& c, std::uint64_t budget) {
  fmt::print(stderr, "{:<8} {:<24} {:>10} {:>8}  {}\n", "method", "size", "file bytes", "PSNR dB",
             "");
  for (std::size_t k = 0; k < c.candidates.size(); ++k) {
    const BudgetCandidate& b = c.candidates[k];
    fmt::print(stderr, "{:<8} {:<24} {:>10} {:>8}  {}\n", b.method, size_text(b), b.file_bytes,
               db_text(b.psnr_db), k == c.chosen ? "chosen" : (b.fits ? "" : "over the budget"));
  }
  for (const BudgetProbe& p : c.probes)
    fmt::print(stderr, "probe    {} {}: {} bytes, a full fit's predicted at {:.0f}\n", p.method,
               p.settings, p.file_bytes, p.predicted_bytes);
  for (const PredictedSize& p : c.not_fitted)
    fmt::print(stderr,
               "not fit  {} {}: its file predicted at {:.0f} bytes by the line through {} and "
               "{}, over the budget\n",
               p.method, p.settings, p.predicted_bytes, p.from, p.to);
  for (const SkippedSetting& s : c.skipped)
    fmt::print(stderr, "skipped  {} {}: {}\n", s.method, s.settings, command_line_text(s.message));
  for (const std::string& m : c.synthesis_methods)
    fmt::print(stderr, "left out {}: it synthesises new texture, no pixel-wise PSNR\n", m);
  const BudgetCandidate& b = c.candidates[c.chosen];
  fmt::print(stderr,
             "chose {} {}: {} bytes of the {} budgeted, the highest PSNR ({} dB) of the "
             "candidates that fit (each method's largest size whose file fits: its ladder of "
             "sizes, as sweep fits it, walked up, then the sizes between rungs and above the "
             "largest predicted and confirmed, or, for a method with a quick search, its size "
             "predicted from short fits; every file as fit writes it by default)\n",
             b.method, size_text(b), b.file_bytes, budget, db_text(b.psnr_db));
}

// What the search will do, before it starts: each method's search and its most fits.
void print_plan(const BudgetRequest& r, const Btf& tile) {
  const ModelFrame frame = ModelFrame::of(tile);
  for (const MethodInfo& m : all_methods()) {
    if (!r.methods.empty() &&
        std::find(r.methods.begin(), r.methods.end(), m.name) == r.methods.end())
      continue;
    const std::size_t rungs = m.ladder(frame).size();
    if (m.synthesises)
      fmt::print(stderr, "  {:<8} left out: it synthesises new texture, no pixel-wise PSNR\n",
                 m.name);
    else if (m.quick_search.probe && !r.exhaustive)
      fmt::print(stderr, "  {:<8} quick: {}; at most {} probes and 2 full fits\n", m.name,
                 m.quick_search.summary, std::max<std::size_t>(rungs, 2));
    else
      fmt::print(stderr,
                 "  {:<8} its ladder's {} sizes walked up while the file fits, then the sizes "
                 "between or above them\n",
                 m.name, rungs);
  }
}

}  // namespace

void run_budget_fit(const FitArguments& o) {
  BudgetRequest r;
  r.options = o.options;
  r.given = o.fields;
  btfgmm::check_fit_options(r.options, r.given, FitRoute::kBudget,
                            o.given.count("--budget") ? "budget" : "ratio");
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit --budget needs an input BTF and -o MODEL");
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  BtfSource src = BtfSource::open(o.input);
  const Btf tile = src.load(tile_option(src, o.tile, o.quiet));
  r.budget = budget_bytes(o, tile);
  if (r.budget == 0)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("--ratio {:g}: the tile's {:.0f} data bytes over it leave no byte; give "
                    "a smaller ratio",
                    o.ratio, ModelFrame::of(tile).data_values()));
  r.source = {o.input, src.info().width, src.info().height};
  r.option_spelling = command_line_option;
  r.exhaustive = o.exhaustive;
  double last = 0.0;  // when a fit's progress was last printed
  // The fit's stage under way and when it began: its time left, at its pace so far, is
  // (elapsed in it) (1 - fraction) / fraction; its fraction is of the stage's bound (EM's most
  // iterations, the refinement's most steps), so the stage may end sooner by its rule.
  std::string stage;
  double stage_began = 0.0, last_event = 0.0;  // a stage begins at the event before its first
  if (!o.quiet) {
    fmt::print(stderr, "budget {} bytes for the {}x{} tile ({:.0f} data bytes, 1:{:.1f})\n",
               r.budget, tile.width(), tile.height(), ModelFrame::of(tile).data_values(),
               ModelFrame::of(tile).data_values() / double(r.budget));
    print_plan(r, tile);
    r.progress = [&](const SweepProgress& p) {
      const double now = seconds_since(t0);
      if (p.event == SweepProgress::Event::kStart) {
        fmt::print(stderr, "fitting {} {} ({})\n", p.method, p.settings, human_seconds(now));
        last = last_event = now;
        stage.clear();
      } else if (p.event == SweepProgress::Event::kFit) {
        if (p.stage != stage) {
          stage = p.stage;
          stage_began = last_event;
        }
        last_event = now;
        if (now - last < 15.0) return;
        const std::string left =
            p.fraction >= 0.02 && p.fraction < 1.0
                ? fmt::format(", about {} left of this stage at its pace",
                              human_seconds((now - stage_began) * (1.0 - p.fraction) / p.fraction))
                : std::string();
        fmt::print(stderr, "  {} {}: {} {:.0f}% ({}{})\n", p.method, p.settings, p.stage,
                   100.0 * p.fraction, human_seconds(now), left);
        last = now;
      }
    };
  }
  r.stop = &g_stop;
  BudgetChoice c;
  {
    const StopOnSignals stop_on_signals;
    c = choose_within_budget(tile, r);
  }
  write_file_atomically(o.out, c.file, "model file");
  if (o.quiet) return;
  print_candidates(c, r.budget);
  fmt::print(
      stderr, "wrote {}: {} {}, {} bytes, compression 1:{:.1f} (file), {} candidates in {}\n",
      o.out, c.model->method(), c.model->size_text(), c.file.size(),
      c.model->file_ratio(c.file.size()), c.candidates.size(), human_seconds(seconds_since(t0)));
}

}  // namespace btfgmm::cli
