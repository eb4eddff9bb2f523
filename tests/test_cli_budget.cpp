// `btfgmm fit --budget BYTES` and `--ratio R`: the method and size that decode the tile best
// within the budget, the candidates it tried, and its errors.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

test::CliRun run(const std::string& args) {
  return test::run_cli(args, "budget_test");
}

struct Row {
  std::string method, size, mark;
  std::uint64_t bytes = 0;
  std::string psnr;  // as printed, 2 decimals
};

bool all_digits(const std::string& t) {
  return !t.empty() && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// "123.45": digits, a point, two digits.
bool two_decimals(const std::string& t) {
  const auto dot = t.find('.');
  return dot != std::string::npos && all_digits(t.substr(0, dot)) && t.size() == dot + 3 &&
         all_digits(t.substr(dot + 1));
}

// One row of the candidates' table fit --budget prints on stderr: method, size (words),
// file bytes, PSNR with two decimals, then "chosen", "over the budget" or nothing.
std::optional<Row> candidate_row(std::string line) {
  Row r;
  for (const char* mark : {"chosen", "over the budget"}) {
    const std::string m = mark;
    if (line.size() > m.size() && line.ends_with(m)) {
      r.mark = m;
      line.resize(line.size() - m.size());
    }
  }
  std::istringstream words(line);
  std::vector<std::string> w;
  for (std::string t; words >> t;) w.push_back(t);
  if (w.size() < 4 || !two_decimals(w.back()) || !all_digits(w[w.size() - 2])) return std::nullopt;
  r.method = w.front();
  r.psnr = w.back();
  r.bytes = std::stoull(w[w.size() - 2]);
  for (std::size_t k = 1; k + 2 < w.size(); ++k) r.size += (k > 1 ? " " : "") + w[k];
  return r;
}

// The candidates' table fit --budget prints on stderr.
std::vector<Row> candidates(const std::string& err) {
  std::vector<Row> out;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);)
    if (const auto r = candidate_row(line)) out.push_back(*r);
  return out;
}

TEST(BudgetCli, ChoosesTheBestCandidateThatFits) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_budget_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d = dir.string();
  test::CliRun r =
      run("generate --material knit --size 8 --seed 2 --lights rings:0/1,30/4,60/4 "
          "--views rings:0/1,45/4 -o " +
          d + "/btf");
  ASSERT_EQ(r.status, 0) << r.err;
  // --ratio 3: the 8 x 8 x 9 x 5 x 3 = 8640 data bytes over 3.
  r = run("fit " + d + "/btf --ratio 3 --iterations 2 -o " + d + "/b.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("budget 2880 bytes"), std::string::npos) << r.err;
  const std::vector<Row> rows = candidates(r.err);
  ASSERT_GE(rows.size(), 4u) << r.err;
  const Row* chosen = nullptr;
  std::uint64_t least = rows[0].bytes;
  for (const Row& row : rows) {
    if (row.mark == "chosen") {
      EXPECT_EQ(chosen, nullptr) << "two chosen:\n" << r.err;
      chosen = &row;
    }
    EXPECT_EQ(row.mark == "over the budget", row.bytes > 2880) << row.method << " " << row.size;
    least = std::min(least, row.bytes);
  }
  ASSERT_NE(chosen, nullptr) << r.err;
  EXPECT_LE(chosen->bytes, 2880u);
  EXPECT_EQ(fs::file_size(d + "/b.btfgmm"), chosen->bytes);
  for (const Row& row : rows) {
    if (row.mark == "over the budget") continue;
    EXPECT_GE(std::stod(chosen->psnr), std::stod(row.psnr)) << row.method << " " << row.size;
  }
  // The texture models are left out: no pixel-wise PSNR. The neural BTF is a candidate.
  EXPECT_NE(r.err.find("left out 3d-car"), std::string::npos) << r.err;
  EXPECT_TRUE(std::any_of(rows.begin(), rows.end(), [](const Row& row) {
    return row.method == "neural";
  })) << r.err;
  // The file is the model chosen: its PSNR as compare measures it, its provenance says why.
  r = run("compare " + d + "/btf " + d + "/b.btfgmm --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(fmt::format("{:.2f}", j["psnr_db"].get<double>()), chosen->psnr);
  EXPECT_EQ(j["method"], chosen->method);
  r = run("info " + d + "/b.btfgmm");
  EXPECT_NE(r.out.find("chosen by --budget 2880 bytes"), std::string::npos) << r.out;

  // Below every rung: the sizes under the smallest are searched (the mixture down to M = 1).
  r = run("fit " + d + "/btf --budget 1000 --iterations 2 --exhaustive -o " + d + "/c.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const Row& row : candidates(r.err)) least = std::min(least, row.bytes);
  EXPECT_LT(least, 1000u) << r.err;
  // A budget below every method's smallest file names it truly: that budget fits, one less not.
  r = run("fit " + d + "/btf --budget 500 --iterations 2 --exhaustive -o " + d +
          "/c.btfgmm --overwrite");
  EXPECT_EQ(r.status, 1);
  const std::string named = "the smallest possible for this tile is ";
  const std::size_t at = r.err.find(named);
  ASSERT_NE(at, std::string::npos) << r.err;
  const std::uint64_t smallest = std::stoull(r.err.substr(at + named.size()));
  EXPECT_NE(r.err.find("(gm M = 1)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(fmt::format("give --budget {} or more", smallest)), std::string::npos);
  r =
      run(fmt::format("fit {}/btf --budget {} --iterations 2 --exhaustive -o {}/c.btfgmm "
                      "--overwrite",
                      d, smallest, d));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(fs::file_size(d + "/c.btfgmm"), smallest);
  fs::remove(d + "/c.btfgmm");
  r = run(fmt::format("fit {}/btf --budget {} --iterations 2 --exhaustive -o {}/c.btfgmm", d,
                      smallest - 1, d));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_FALSE(fs::exists(d + "/c.btfgmm"));
  // The budget chooses the method and size: naming either is an error naming both.
  r = run("fit " + d + "/btf --budget 5000 --method pca-btf -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--method cannot apply with --budget"), std::string::npos) << r.err;
  r = run("fit " + d + "/btf --ratio 4 -M 3 -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("-M/--components cannot apply with --ratio"), std::string::npos) << r.err;
  r = run("fit " + d + "/btf --budget 5000 --levels 2 -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--levels cannot apply with --budget"), std::string::npos) << r.err;
  r = run("fit " + d + "/btf --ratio 4 --budget 100 -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--budget and --ratio"), std::string::npos) << r.err;
  r = run("fit " + d + "/btf --exhaustive -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--exhaustive"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// The mixture's size in a row's size text, "M = 37".
std::size_t mixture_size(const Row& row) {
  return std::stoul(row.size.substr(row.size.find('=') + 1));
}

// A method's largest size among the candidates that fit and its least over the budget (0 if
// none).
std::pair<std::size_t, std::size_t> largest_fit_and_least_over(const std::vector<Row>& rows,
                                                               const std::string& method) {
  std::size_t largest_fit = 0, least_over = 0;
  for (const Row& row : rows) {
    if (row.method != method) continue;
    const std::size_t m = mixture_size(row);
    if (row.mark != "over the budget")
      largest_fit = std::max(largest_fit, m);
    else if (least_over == 0 || m < least_over)
      least_over = m;
  }
  return {largest_fit, least_over};
}

// Within a budget that a plain fit's file fits, for a size of the ladder (the default fit,
// M = 600, is the mixture's top rung), the choice is at least as good; and the mixture's
// search ends on the largest M whose file fits: M + 1 was tried and is over.
TEST(BudgetCli, NeverWorseThanAPlainFitAndFindsTheLargestSizeThatFits) {
  EXPECT_EQ(find_method("gm").ladder(ModelFrame{}).back().components,
            mixture_config(0, 0, 1, 0).components);
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_budget_default_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d = dir.string();
  // 10 x 10 x 6 lights x 5 views: 3000 samples, up to M = 46 (30, a rung, is the plain fit).
  test::CliRun r =
      run("generate --material corduroy --size 10 --seed 4 --lights rings:0/1,30/5 "
          "--views rings:0/1,45/4 -o " +
          d + "/btf");
  ASSERT_EQ(r.status, 0) << r.err;
  // The refinement bounded in epochs: the same models at any load of the machine.
  r = run("fit " + d + "/btf -M 30 --iterations 2 --refine-epochs 2 -o " + d + "/default.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("compare " + d + "/btf " + d + "/default.btfgmm --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const double default_psnr = nlohmann::json::parse(r.out)["psnr_db"].get<double>();
  // The chosen file carries the choice's note: room for it.
  const std::uint64_t budget = fs::file_size(dir / "default.btfgmm") + 200;
  r = run(fmt::format(
      "fit {}/btf --budget {} --iterations 2 --refine-epochs 2 --exhaustive -o {}/b.btfgmm", d,
      budget, d));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<Row> rows = candidates(r.err);
  const Row* chosen = nullptr;
  for (const Row& row : rows)
    if (row.mark == "chosen") chosen = &row;
  ASSERT_NE(chosen, nullptr) << r.err;
  EXPECT_GE(std::stod(chosen->psnr), std::floor(default_psnr * 100) / 100) << r.err;
  // Its mixtures were refined for 2 epochs at most, as the plain fit was: the file says so.
  if (chosen->method == "gm") {
    r = run("info " + d + "/b.btfgmm");
    EXPECT_NE(r.out.find("refine epochs 2"), std::string::npos) << r.out;
  }

  // A budget between the mixture's rungs: its largest M that fits, the next one over.
  r = run(fmt::format("fit {}/btf --budget {} --iterations 2 --exhaustive -o {}/c.btfgmm", d,
                      budget / 2, d));
  ASSERT_EQ(r.status, 0) << r.err;
  const auto [largest_fit, least_over] = largest_fit_and_least_over(candidates(r.err), "gm");
  ASSERT_GT(largest_fit, 0u) << r.err;
  ASSERT_GT(least_over, 0u) << r.err;
  EXPECT_EQ(least_over, largest_fit + 1) << r.err;

  // A budget above the largest rung the tile allows (M = 30; M = 100 is refused): the sizes
  // above it are searched too, up to the largest M whose file fits or the tile supports.
  r = run(fmt::format("fit {}/btf --budget {} --iterations 2 --exhaustive -o {}/e.btfgmm", d,
                      budget * 5 / 4, d));
  ASSERT_EQ(r.status, 0) << r.err;
  const auto [largest, over] = largest_fit_and_least_over(candidates(r.err), "gm");
  EXPECT_GT(largest, 30u) << r.err;
  const bool next_refused =
      r.err.find(fmt::format("skipped  gm components {},", largest + 1)) != std::string::npos;
  EXPECT_TRUE(over == largest + 1 || next_refused) << r.err;
  fs::remove_all(dir);
}

// The best PSNR of `method`'s candidates that fit (0 if none).
double best_that_fits(const std::vector<Row>& rows, const std::string& method) {
  double best = 0.0;
  for (const Row& row : rows)
    if (row.method == method && row.mark != "over the budget")
      best = std::max(best, std::stod(row.psnr));
  return best;
}

// The quick search (the default): the mixture's size predicted from probes (short fits whose
// files are counted, not measured), one size fitted in full (or two, when the first is over by
// more than coarser steps save), its file within the budget, and its PSNR near that of the
// exhaustive search, which fits every size it tries in full.
TEST(BudgetCli, QuickSearchFitsOneMixtureNearTheExhaustiveChoice) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_budget_quick_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d = dir.string();
  test::CliRun r =
      run("generate --material corduroy --size 12 --seed 4 --lights rings:0/1,30/5,60/6 "
          "--views rings:0/1,45/4 -o " +
          d + "/btf");
  ASSERT_EQ(r.status, 0) << r.err;
  // Between the mixture's rungs M = 30 and 100 (about 2,650 and 4,700 bytes here), where the
  // pixel-wise factor methods are near it; the refinement as by default (it ends by its rule).
  r = run("fit " + d + "/btf --budget 3500 -o " + d + "/quick.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("gm       quick:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("probe    gm components"), std::string::npos) << r.err;
  const std::vector<Row> quick = candidates(r.err);
  const std::string quick_err = r.err;
  std::size_t mixtures = 0;
  const Row* quick_choice = nullptr;
  for (const Row& row : quick) {
    mixtures += row.method == "gm";
    if (row.mark == "chosen") quick_choice = &row;
  }
  EXPECT_GE(mixtures, 1u) << r.err;
  EXPECT_LE(mixtures, 3u) << r.err;  // a refit, and one stored with coarser steps, at most
  ASSERT_NE(quick_choice, nullptr) << r.err;
  EXPECT_LE(fs::file_size(d + "/quick.btfgmm"), 3500u);
  EXPECT_EQ(fs::file_size(d + "/quick.btfgmm"), quick_choice->bytes);

  r = run("fit " + d + "/btf --budget 3500 --exhaustive -o " + d + "/exhaustive.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<Row> exhaustive = candidates(r.err);
  const Row* exhaustive_choice = nullptr;
  for (const Row& row : exhaustive)
    if (row.mark == "chosen") exhaustive_choice = &row;
  ASSERT_NE(exhaustive_choice, nullptr) << r.err;
  EXPECT_GT(exhaustive.size(), quick.size()) << r.err;
  EXPECT_GE(std::stod(quick_choice->psnr), std::stod(exhaustive_choice->psnr) - 0.5);
  // The mixture's own best within the budget: the quick search's one fit against the best of
  // the exhaustive search's (every rung and every size between fitted in full).
  const double quick_mixture = best_that_fits(quick, "gm");
  const double exhaustive_mixture = best_that_fits(exhaustive, "gm");
  EXPECT_GT(exhaustive_mixture, 0.0) << r.err;
  EXPECT_GE(quick_mixture, exhaustive_mixture - 0.3) << r.err;
  // The other methods: a size whose file the line through two fitted puts well over the budget
  // is not fitted by the quick search (here PCA BTF's c = 10), and nothing is lost by it: each
  // method's best that fits is the exhaustive search's, which fitted that size, over the budget.
  EXPECT_NE(quick_err.find("not fit  pca-btf components 10: its file predicted at"),
            std::string::npos)
      << quick_err;
  EXPECT_EQ(r.err.find("not fit"), std::string::npos) << r.err;
  bool fitted_over = false;
  for (const Row& row : exhaustive)
    fitted_over |= row.method == "pca-btf" && row.size == "c = 10" && row.mark == "over the budget";
  EXPECT_TRUE(fitted_over) << r.err;
  for (const char* m : {"pca-btf", "pca-rf", "lpca", "ptm-rf", "plm-rf"})
    EXPECT_EQ(best_that_fits(quick, m), best_that_fits(exhaustive, m)) << m;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
