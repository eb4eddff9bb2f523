// The command with provenance: compare and render --compare refuse other data, info shows the
// provenance, fit refuses options that cannot apply, resumes and continues to --iterations,
// logs its iterations (--log) and says nothing with -q.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/fit.hpp"
#include "test_util.hpp"

namespace {

namespace fs = std::filesystem;

using btfgmm::test::CliRun;

CliRun run(const std::string& args) {
  return btfgmm::test::run_cli(args, "cli_prov");
}

bool has(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

const char* kSets = "--lights rings:0/1,30/4,60/6 --views rings:0/1,45/5";

// Two generated materials of the same size and directions (made once for all the tests), and
// a folder of each test's own.
class CliProvenance : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = fs::temp_directory_path() / ("btfgmm_cli_prov_data_" + std::to_string(::getpid()));
    fs::remove_all(data_);
    for (const char* m : {"corduroy", "knit"})
      ASSERT_EQ(run(std::string("generate --size 8 --material ") + m + " " + kSets + " -o " +
                    (data_ / m).string())
                    .status,
                0);
  }
  static void TearDownTestSuite() { fs::remove_all(data_); }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("btfgmm_cli_prov_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The data sets by name, other files in the test's folder.
  std::string p(const std::string& name) const {
    return (name == "corduroy" || name == "knit" ? data_ / name : dir_ / name).string();
  }
  CliRun fit(const std::string& args) { return run("fit " + p("corduroy") + " " + args); }
  static inline fs::path data_;
  fs::path dir_;
};

TEST_F(CliProvenance, CompareRefusesOtherDataNamingBoth) {
  ASSERT_EQ(fit("-M 4 --iterations 2 -q -o " + p("c.btfgmm")).status, 0);
  ASSERT_EQ(fit("--method pca-btf --components 2 -q -o " + p("pca.btfgmm")).status, 0);
  CliRun r = run("compare " + p("knit") + " " + p("c.btfgmm"));
  EXPECT_EQ(r.status, 1) << r.err;
  const nlohmann::json info = nlohmann::json::parse(run("info --json " + p("c.btfgmm")).out);
  const std::string hash = info["provenance"]["content_hash"];
  for (const std::string& needle :
       {"'" + p("knit") + "' is not the data", std::string("partial match"),
        "'" + p("corduroy") + "'", hash, std::string("--force")})
    EXPECT_TRUE(has(r.err, needle)) << needle << ": " << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  r = run("compare " + p("knit") + " " + p("pca.btfgmm") + " --json");
  EXPECT_EQ(r.status, 1) << r.err;
  // --force measures anyway, and says so.
  r = run("compare " + p("knit") + " " + p("c.btfgmm") + " --json --force");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.err, "warning: ")) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["data_match"], "other content");
  // The data it was fitted to: unchanged, and "same".
  r = run("compare " + p("corduroy") + " " + p("c.btfgmm") + " " + p("pca.btfgmm") + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j[0]["data_match"], "same");
  EXPECT_EQ(j[1]["data_match"], "same");
  EXPECT_FALSE(has(r.err, "warning")) << r.err;
  // render --compare the same way.
  const std::string render =
      "render " + p("c.btfgmm") + " --size 48 --overwrite -o " + p("r.png") + " --compare ";
  r = run(render + p("knit"));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(has(r.err, hash) && has(r.err, "render anyway")) << r.err;
  EXPECT_FALSE(fs::exists(p("r.png")));
  EXPECT_EQ(run(render + p("knit") + " --force").status, 0);
  EXPECT_EQ(run(render + p("corduroy")).status, 0);
}

TEST_F(CliProvenance, OlderModelsAreComparedWithANote) {
  const fs::path data = BTFGMM_TEST_DATA;
  CliRun r = run("compare " + p("corduroy") + " " + (data / "golden_v2_gm.btfgmm").string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.err, "note: ") && has(r.err, "records no provenance")) << r.err;
  r = run("info " + (data / "golden_v2_pca-btf.btfgmm").string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.out, "btfgmm format 2")) << r.out;
  EXPECT_TRUE(has(r.out, "provenance   none recorded")) << r.out;
  r = run("info --json " + (data / "golden_v1.btfgmm").string());
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format_version"], 1);
  EXPECT_TRUE(j["provenance"].is_null());
}

TEST_F(CliProvenance, InfoShowsTheProvenanceAndTheUnits) {
  ASSERT_EQ(fit("-M 4 --iterations 3 --seed 5 -q -o " + p("c.btfgmm")).status, 0);
  CliRun r = run("info " + p("c.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* needle : {"btfgmm format 8", "fitted to    '", "content hash ", "seed 5",
                             "3 logged", "nats per sample", "model units  x, y 1 pixel"})
    EXPECT_TRUE(has(r.out, needle)) << needle << ": " << r.out;
  EXPECT_FALSE(has(r.out, "(model units)")) << r.out;
  r = run("info --json " + p("c.btfgmm"));
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["provenance"]["source"], p("corduroy"));
  EXPECT_EQ(j["provenance"]["image_size"], nlohmann::json({8, 8}));
  EXPECT_EQ(j["provenance"]["settings"]["seed"], "5");
  ASSERT_EQ(j["provenance"]["iterations"].size(), 3u);
  EXPECT_TRUE(j["provenance"]["iterations"][0]["relative_gain"].is_null());
}

// The progress: no gain for the first iteration; the final L explained; --log; -q silent.
TEST_F(CliProvenance, FitOutputLogAndQuiet) {
  CliRun r = fit("-M 4 --iterations 3 -o " + p("c.btfgmm") + " --log " + p("log.jsonl"));
  ASSERT_EQ(r.status, 0) << r.err;
  std::istringstream lines(r.err);
  std::string line, first, last;
  while (std::getline(lines, line))
    if (line.rfind("iteration ", 0) == 0) (first.empty() ? first : last) = line;
  EXPECT_FALSE(has(first, "gain")) << first;
  EXPECT_TRUE(has(last, "gain +")) << last;
  std::ifstream log(p("log.jsonl"));
  std::vector<nlohmann::json> its;
  while (std::getline(log, line)) its.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(its.size(), 3u);
  EXPECT_TRUE(its[0]["relative_gain"].is_null());
  EXPECT_EQ(its[2]["iteration"], 3);
  const nlohmann::json info = nlohmann::json::parse(run("info --json " + p("c.btfgmm")).out);
  EXPECT_EQ(its[2]["log_likelihood"], info["provenance"]["iterations"][2]["log_likelihood"]);
  // The written L is of the refined parameters, said so; the line says which L the last
  // iteration showed.
  EXPECT_TRUE(has(r.err,
                  "of the parameters written, after the refinement for the prediction, "
                  "which trades L for the prediction's error (iteration 3 showed L = "))
      << r.err;
  // CSV by the name; -q prints nothing at all.
  r = fit("-M 4 --iterations 3 -q -o " + p("q.btfgmm") + " --log " + p("log.csv"));
  ASSERT_EQ(r.status, 0);
  EXPECT_EQ(r.err + r.out, "");
  std::ifstream csv(p("log.csv"));
  std::getline(csv, line);
  EXPECT_EQ(line, "iteration,log_likelihood,relative_gain,components,dropped,seconds");
  r = fit("--method pca-btf --components 2 -q -o " + p("pca.btfgmm"));
  ASSERT_EQ(r.status, 0);
  EXPECT_EQ(r.err + r.out, "");
}

// A checkpoint of a fit stopped after 2 of 4 iterations, made through the library.
std::string interrupted_checkpoint(const std::string& btf, const std::string& dir) {
  btfgmm::FitRequest r;
  r.input = btf;
  r.output = dir + "/r.btfgmm";
  r.checkpoint = dir + "/r.ckpt";
  r.config.components = 4;
  r.config.em.max_iterations = 4;
  std::atomic<bool> stop{false};
  r.config.em.stop = &stop;
  btfgmm::FitObserver o;
  o.iteration = [&](const btfgmm::EmProgress& p) { stop = p.iteration >= 2; };
  EXPECT_TRUE(btfgmm::run_fit(r, o).interrupted);
  return r.checkpoint;
}

TEST_F(CliProvenance, ResumeRefusesOptionsThatCannotApplyAndGoesOnToIterations) {
  const std::string ckpt = interrupted_checkpoint(p("corduroy"), dir_.string());
  CliRun r = run("fit --resume " + ckpt + " -M 5 --tile 0,0,8,8 --iterations 6");
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, "--tile, -M/--components cannot apply with --resume")) << r.err;
  EXPECT_FALSE(has(r.err, "--iterations")) << r.err;
  EXPECT_FALSE(fs::exists(p("r.btfgmm")));
  r = run("fit --resume " + ckpt + " --seed 1 --overwrite");
  EXPECT_TRUE(has(r.err, "--seed, --overwrite cannot apply")) << r.err;
  r = run("fit --resume " + ckpt + " --iterations 6");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.err, "resuming from")) << r.err;
  EXPECT_TRUE(has(r.err, "iteration   6/6")) << r.err;
  EXPECT_TRUE(has(r.err, "in all, ") && has(r.err, "in this run from iteration 3 on")) << r.err;
  const nlohmann::json j = nlohmann::json::parse(run("info --json " + p("r.btfgmm")).out);
  EXPECT_EQ(j["iterations"], 6);
  EXPECT_EQ(j["provenance"]["runs"], 1);  // resumed, one fit: the file of one never stopped
  EXPECT_EQ(j["provenance"]["iterations"].size(), 6u);
}

TEST_F(CliProvenance, ContinueGoesOnWithAFinishedMixture) {
  ASSERT_EQ(fit("-M 4 --iterations 2 -q -o " + p("two.btfgmm")).status, 0);
  ASSERT_EQ(fit("--method pca-btf --components 2 -q -o " + p("pca.btfgmm")).status, 0);
  CliRun r = run("fit --continue " + p("two.btfgmm") + " -o " + p("more.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, "needs --iterations N")) << r.err;
  r = run("fit --continue " + p("two.btfgmm") + " --iterations 4 --seed 3 -o " + p("more.btfgmm"));
  EXPECT_TRUE(has(r.err, "--seed cannot apply with --continue")) << r.err;
  r = run("fit --continue " + p("pca.btfgmm") + " --iterations 4 -o " + p("more.btfgmm"));
  EXPECT_TRUE(has(r.err, "holds a 'pca-btf' model")) << r.err;
  r = run("fit " + p("knit") + " --continue " + p("two.btfgmm") + " --iterations 4 -o " +
          p("more.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, "is not what model")) << r.err;
  r = run("fit --continue " + p("two.btfgmm") + " --iterations 4 -o " + p("more.btfgmm") +
          " --log " + p("more.jsonl"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.err, "continuing " + p("two.btfgmm") + " after iteration 2")) << r.err;
  const nlohmann::json j = nlohmann::json::parse(run("info --json " + p("more.btfgmm")).out);
  EXPECT_EQ(j["iterations"], 4);
  std::ifstream log(p("more.jsonl"));
  int lines = 0;
  for (std::string line; std::getline(log, line);) ++lines;
  EXPECT_EQ(lines, 4);  // the model's two iterations, then the two run now
  // Other methods take none of the mixture's EM options.
  r = fit("--method pca-btf --components 2 --log " + p("x.jsonl") + " -o " + p("p2.btfgmm"));
  EXPECT_TRUE(has(r.err, "--log cannot apply to --method pca-btf")) << r.err;
  r = fit("--method pca-btf --components 2 --epsilon 0 -o " + p("p2.btfgmm"));
  EXPECT_TRUE(has(r.err, "--epsilon cannot apply to --method pca-btf")) << r.err;
  EXPECT_FALSE(fs::exists(p("p2.btfgmm")));
}

}  // namespace
