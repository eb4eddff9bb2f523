// btfgmm fit --budget / --ratio: see budget_fit.hpp.
#include <fmt/format.h>

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

// The candidates tried, on stderr: method, size, true file bytes, PSNR, the one chosen.
void print_candidates(const BudgetChoice& c, std::uint64_t budget) {
  fmt::print(stderr, "{:<8} {:<24} {:>10} {:>8}  {}\n", "method", "size", "file bytes", "PSNR dB",
             "");
  for (std::size_t k = 0; k < c.candidates.size(); ++k) {
    const BudgetCandidate& b = c.candidates[k];
    fmt::print(stderr, "{:<8} {:<24} {:>10} {:>8}  {}\n", b.method, b.size, b.file_bytes,
               db_text(b.psnr_db), k == c.chosen ? "chosen" : (b.fits ? "" : "over the budget"));
  }
  for (const SkippedSetting& s : c.skipped)
    fmt::print(stderr, "skipped  {} {}: {}\n", s.method, s.settings, command_line_text(s.message));
  for (const std::string& m : c.synthesis_methods)
    fmt::print(stderr, "left out {}: it synthesises new texture, no pixel-wise PSNR\n", m);
  const BudgetCandidate& b = c.candidates[c.chosen];
  fmt::print(stderr,
             "chose {} {}: {} bytes of the {} budgeted, the highest PSNR ({} dB) of the "
             "candidates that fit (each method's largest size whose file fits: its ladder of "
             "sizes, as sweep fits it, walked up, then the sizes between rungs and above the "
             "largest predicted and confirmed; every file as fit writes it by default)\n",
             b.method, b.size, b.file_bytes, budget, db_text(b.psnr_db));
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
  const BtfSource src = BtfSource::open(o.input);
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
  if (!o.quiet) {
    fmt::print(stderr, "budget {} bytes for the {}x{} tile ({:.0f} data bytes, 1:{:.1f})\n",
               r.budget, tile.width(), tile.height(), ModelFrame::of(tile).data_values(),
               ModelFrame::of(tile).data_values() / double(r.budget));
    r.progress = [&](const SweepProgress& p) {
      if (p.event == SweepProgress::Event::kStart)
        fmt::print(stderr, "fitting {} {} ({})\n", p.method, p.settings,
                   human_seconds(seconds_since(t0)));
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
