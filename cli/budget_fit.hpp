// `btfgmm fit --budget BYTES` and `--ratio R`: the method and size that decode the tile best
// within a budget of true file bytes (btfgmm/measure/budget.hpp), written as the model.
#pragma once

#include <cstdint>
#include <string>

namespace btfgmm::cli {

struct BudgetFitArguments {
  std::string input, out, tile;
  std::uint64_t budget = 0;  // 0: from ratio
  double ratio = 0.0;        // 0: budget given
  std::uint64_t seed = 1;
  int threads = 0, iterations = 0;
  double refine_seconds = 0.0;  // 0: the mixture's refinement bounded by its default time
  int refine_epochs = 0;
  bool overwrite = false, quiet = false;
};

void run_budget_fit(const BudgetFitArguments& o);

}  // namespace btfgmm::cli
