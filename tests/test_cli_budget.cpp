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
  // The texture models are left out: no pixel-wise PSNR.
  EXPECT_NE(r.err.find("left out 3d-car"), std::string::npos) << r.err;
  // The file is the model chosen: its PSNR as compare measures it, its provenance says why.
  r = run("compare " + d + "/btf " + d + "/b.btfgmm --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(fmt::format("{:.2f}", j["psnr_db"].get<double>()), chosen->psnr);
  EXPECT_EQ(j["method"], chosen->method);
  r = run("info " + d + "/b.btfgmm");
  EXPECT_NE(r.out.find("chosen by --budget 2880 bytes"), std::string::npos) << r.out;

  // A budget below every file names the smallest possible (a 4-digit budget's note, as above).
  r = run("fit " + d + "/btf --budget 1000 --iterations 2 -o " + d + "/c.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(fmt::format("the smallest possible for this tile is {} bytes", least)),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(fmt::format("give --budget {} or more", least)), std::string::npos);
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
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
