// The best model within a budget of file bytes; see budget.hpp.
#include "btfgmm/measure/budget.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
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
                                           const MethodInfo& method, const MethodSettings& s,
                                           BudgetChoice& out) {
  SweepRequest q;
  q.source = r.source;
  q.methods = {std::string(method.name)};
  q.ladders[std::string(method.name)] = {s};
  q.threads = r.threads;
  q.seed = r.seed;
  q.iterations = method.name == kMixtureMethod ? r.iterations : 0;
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
  const ModelFrame frame = ModelFrame::of(tile);
  BudgetChoice out;
  bool any = false;
  std::shared_ptr<Representation> smallest;  // the smallest file fitted
  std::uint64_t smallest_bytes = 0;
  for (const MethodInfo* m : methods)
    for (const MethodSettings& s : m->ladder(frame)) {  // smallest model first
      std::optional<ModelComparison> c = fit_setting(tile, r, *m, s, out);
      if (!c) continue;
      if (c->model->synthesises()) {
        out.synthesis_methods.push_back(std::string(m->name));
        break;
      }
      NotedModel n = with_note(*c->model, r.budget, r, c->name);
      out.candidates.push_back({std::string(m->name), settings_text(s), c->model->size_text(),
                                n.file.size(), c->quality.psnr_db, n.file.size() <= r.budget});
      if (!smallest || n.file.size() < smallest_bytes) {
        smallest = n.model;
        smallest_bytes = n.file.size();
      }
      if (!out.candidates.back().fits) break;  // the larger sizes only grow
      if (!any || c->quality.psnr_db > out.candidates[out.chosen].psnr_db) {
        out.chosen = out.candidates.size() - 1;
        out.model = std::move(n.model);
        out.file = std::move(n.file);
        any = true;
      }
    }
  if (!any) throw nothing_fits(out, r, smallest.get());
  return out;
}

}  // namespace btfgmm
