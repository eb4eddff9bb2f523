// The budget's quick search over the neural BTF's ladder (src/measure/budget.cpp, QuickSearch):
// the ladder's top rungs widen the network and the rungs below them grow the latent, and a
// budget below the widened rungs is searched in the segment of the latent, by probes and one
// full fit, not by a full fit of every rung.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "btfgmm/measure/budget.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

TEST(NeuralBudget, QuickSearchWalksDownToTheSegmentTheBudgetLiesIn) {
  const Btf tile = test::generated_tile("knit", 12, 3, "ubo81", "ubo81");
  const auto ladder = neural_btf_ladder(ModelFrame::of(tile));
  for (const FitOptions& s : ladder)
    std::printf("rung: L = %zu, %zu x %zu\n", s.components, s.depth, s.width);
  // The top rungs differ in the width, the two below them in L.
  ASSERT_GE(ladder.size(), 4u);
  const std::size_t n = ladder.size();
  ASSERT_EQ(ladder[n - 1].components, ladder[n - 2].components);
  ASSERT_LT(ladder[n - 2].width, ladder[n - 1].width);
  BudgetRequest r;
  r.budget = 13500;
  r.methods = {"neural"};
  r.options.iterations = 1;
  r.given = {"iterations"};
  const BudgetChoice c = choose_within_budget(tile, r);
  for (const BudgetProbe& p : c.probes)
    std::printf("probe %s: %llu bytes, predicted %.0f\n", p.settings.c_str(),
                (unsigned long long)p.file_bytes, p.predicted_bytes);
  for (const BudgetCandidate& k : c.candidates)
    std::printf("fitted %s (%s): %llu bytes, %.2f dB\n", k.settings.c_str(), k.size.c_str(),
                (unsigned long long)k.file_bytes, k.psnr_db);
  ASSERT_FALSE(c.candidates.empty());
  const BudgetCandidate& chosen = c.candidates[c.chosen];
  EXPECT_LE(chosen.file_bytes, r.budget);
  EXPECT_TRUE(chosen.fits);
  // One size predicted and fitted in full (twice at most: once more where the first is over).
  EXPECT_LE(c.candidates.size(), 2u);
  // Probed: a widened rung (over the budget), then the rungs of the latent.
  EXPECT_TRUE(std::any_of(c.probes.begin(), c.probes.end(), [](const BudgetProbe& p) {
    return p.predicted_bytes > 13500.0;
  }));
  // The choice is the default network with a latent between the rungs that bracket the budget.
  const auto* model = dynamic_cast<const NeuralBtf*>(c.model.get());
  ASSERT_NE(model, nullptr);
  EXPECT_EQ(model->shape().width, kNeuralDefaultWidth);
  EXPECT_GT(model->shape().latent, 4u);
  EXPECT_LT(model->shape().latent, 16u);
}

}  // namespace
}  // namespace btfgmm
