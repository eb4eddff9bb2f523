// `btfgmm fit --budget BYTES` and `--ratio R`: the method and size that decode the tile best
// within a budget of true file bytes (btfgmm/measure/budget.hpp), written as the model.
#pragma once

#include "fit_command.hpp"

namespace btfgmm::cli {

// The fit within a budget of the arguments' `budget` or `ratio`, their options checked once
// by the library (route kBudget).
void run_budget_fit(const FitArguments& o);

}  // namespace btfgmm::cli
