// The btfgmm command end to end: generate, info, fit, decode, eval, and its errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int status = 0;
  std::string out;  // stdout and stderr together
};

CliRun run(const std::string& args) {
  const fs::path log =
      fs::temp_directory_path() / ("btfgmm_cli_test_" + std::to_string(::getpid()) + ".log");
  const std::string cmd =
      std::string(BTFGMM_CLI_PATH) + " " + args + " > " + log.string() + " 2>&1";
  CliRun r;
  const int raw = std::system(cmd.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  std::ifstream in(log);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return r;
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("btfgmm_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string p(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

const char* kSmall = "--lights rings:0/1,30/4,60/6 --views rings:0/1,45/5";

TEST_F(Cli, GenerateInfoFitInfoEvalDecode) {
  CliRun r =
      run(std::string("generate --material knit --size 8 --seed 3 ") + kSmall + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("info --json " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["lights"], 11);
  EXPECT_EQ(j["views"], 6);
  EXPECT_EQ(j["width"], 8);
  EXPECT_EQ(j["bit_depth"], "8-bit");
  EXPECT_EQ(j["layout"], "UTIA (one folder per view)");

  r = run("fit " + p("btf") + " --tile 0,0,6,6 -M 5 --iterations 3 --seed 2 -o " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("iteration   3/3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ETA"), std::string::npos) << r.out;
  // Before EM, what the fit will take.
  EXPECT_LT(r.out.find("plan: EM on the CPU, at most 3 iterations of M = 5, the first about "),
            r.out.find("iteration   1/3"))
      << r.out;
  // The step bound, here the 1,000 epochs' (one minibatch an epoch on this tile).
  EXPECT_NE(r.out.find("then the refinement for the prediction, at most 1000 Adam steps (about "
                       "1000 epochs of 1 steps)"),
            std::string::npos)
      << r.out;
  // Before the refinement, its time on EM's mixture.
  EXPECT_NE(r.out.find("refining for the prediction: at most 1000 Adam steps, about "),
            std::string::npos)
      << r.out;
  // The refinement for the prediction: its steps, then what it gained.
  EXPECT_NE(r.out.find("refining for the prediction: epoch   1 step 1"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("held-out RMSE "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("training RMSE "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("refined for the prediction in "), std::string::npos) << r.out;
  r = run("fit " + p("btf") +
          " --tile 0,0,6,6 -M 5 --iterations 3 --seed 2 --refine-steps 14 "
          "-o " +
          p("longer.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("refined for the prediction in 14 Adam steps"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("refining for the prediction: epoch  14 step 14/14"), std::string::npos)
      << r.out;
  r = run("info --json " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "model");
  EXPECT_EQ(j["iterations"], 3);
  EXPECT_EQ(j["tile"], nlohmann::json({0, 0, 6, 6}));
  EXPECT_EQ(j["file_bytes"], fs::file_size(p("m.btfgmm")));

  r = run("eval " + p("m.btfgmm") + " --x 3.5 --y 7.25 --light 30,45 --view 10,200 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["rgb"].size(), 3u);

  r = run("decode " + p("m.btfgmm") + " -o " + p("dec"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("info --json " + p("dec"));
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["images"], 66);
  EXPECT_EQ(j["width"], 6);

  r = run("decode " + p("m.btfgmm") + " -o " + p("one") + " --light 30,90 --view 0,0 --size 20x12");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(fs::exists(p("one/tv000_pv000/tl030_pl090_tv000_pv000.png")));
  r = run("info --json " + p("one"));
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["width"], 20);
  EXPECT_EQ(j["height"], 12);
}

// --refine-epochs bounds the refinement in passes over the data, not in time: the fit says
// so before EM and after, records it for --continue, and gives the same model with 1 and 2
// threads (what a time bound cannot promise on a loaded machine); the paper's EM refines
// nothing, so neither bound applies to it.
TEST_F(Cli, ARefinementBoundInEpochsGivesTheSameModelOnAnyMachine) {
  CliRun r = run("generate --size 8 " + std::string(kSmall) + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string fit = "fit " + p("btf") + " -M 5 --iterations 3 --seed 2 --refine-epochs 2 ";
  r = run(fit + "--threads 2 -o " + p("a.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("then the refinement for the prediction, at most 2 epochs of "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("Adam steps (--refine-epochs)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(2 epochs, the epoch bound,"), std::string::npos) << r.out;
  r = run(fit + "--threads 1 -o " + p("b.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("decode " + p("a.btfgmm") + " -q -o " + p("da"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("decode " + p("b.btfgmm") + " -q -o " + p("db"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto contents = [](const fs::path& f) {
    std::ifstream in(f, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  std::size_t images = 0;
  for (const auto& e : fs::recursive_directory_iterator(p("da"))) {
    if (!e.is_regular_file() || e.path().extension() != ".png") continue;
    ++images;
    const fs::path other = p("db") / fs::relative(e.path(), p("da"));
    EXPECT_EQ(contents(e.path()), contents(other)) << other;
  }
  EXPECT_GT(images, 0u);
  r = run("info " + p("a.btfgmm"));
  EXPECT_NE(r.out.find("refine epochs 2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("in 2 epochs (epoch bound)"), std::string::npos) << r.out;
  // Continued, the fit refines again within the epochs it recorded.
  r = run("fit " + p("btf") + " --continue " + p("a.btfgmm") + " --iterations 4 -o " +
          p("c.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("the epoch bound"), std::string::npos) << r.out;
  for (const char* bound : {"--refine-epochs 3", "--refine-seconds 5"}) {
    r = run("fit " + p("btf") + " --objective likelihood " + bound + " -o " + p("l.btfgmm"));
    EXPECT_EQ(r.status, 1) << bound;
    EXPECT_NE(r.out.find("applies to the objective prediction only"), std::string::npos) << r.out;
  }
  r = run("fit " + p("btf") + " --refine-epochs 0 -o " + p("l.btfgmm"));
  EXPECT_NE(r.out.find("--refine-epochs 0: out of range"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("l.btfgmm")));
}

TEST_F(Cli, ErrorsNameTheProblemAndExitNonZero) {
  CliRun r = run("generate --material velvet -o " + p("x"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("velvet"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("x")));

  r = run("fit " + p("nowhere") + " -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("nowhere"), std::string::npos) << r.out;

  r = run("generate --size 8 " + std::string(kSmall) + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  // The output folder is checked before any work.
  r = run("fit " + p("btf") + " -o " + p("missing/m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("does not exist"), std::string::npos) << r.out;
  r = run("fit " + p("btf") + " -M 0 -o " + p("m.btfgmm"));
  EXPECT_NE(r.status, 0);
  r = run("fit " + p("btf") + " --objective likelihood --refine-steps 50 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("--refine-steps applies to the objective prediction only"),
            std::string::npos)
      << r.out;
  r = run("fit " + p("btf") + " --method pca-btf --refine-steps 50 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("--refine-steps cannot apply to --method pca-btf"), std::string::npos)
      << r.out;
  r = run("fit " + p("btf") + " --tile 4,4,8,8 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("tile"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));
  r = run("fit " + p("btf") + " --tile 0,0,2,2 -M 300 --objective likelihood -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("more than"), std::string::npos) << r.out;
  // For the prediction (the default), more components than the tile's samples support are
  // refused before EM, with the most it supports.
  r = run("fit " + p("btf") + " --tile 0,0,2,2 -M 300 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("samples support at most 3 components"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));

  // A truncated model file, and a PNG given as a model.
  r = run("fit " + p("btf") + " -M 3 --iterations 1 -q -o " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  {
    std::ifstream in(p("m.btfgmm"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(p("cut.btfgmm"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  r = run("eval " + p("cut.btfgmm") + " --x 0 --y 0 --light 0,0 --view 0,0");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("cut.btfgmm"), std::string::npos) << r.out;
  r = run("info " + p("btf/tv000_pv000/tl000_pl000_tv000_pv000.png"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("PNG"), std::string::npos) << r.out;

  r = run("eval " + p("m.btfgmm") + " --x 0 --y 0 --light 95,0 --view 0,0");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("theta"), std::string::npos) << r.out;
  r = run("eval " + p("m.btfgmm") + " --x 0 --y 0 --light nan,0 --view 0,0");
  EXPECT_EQ(r.status, 1);
  // Refuses to overwrite without --overwrite.
  r = run("fit " + p("btf") + " -M 3 --iterations 1 -q -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("--overwrite"), std::string::npos) << r.out;
}

// Lines of `text` holding `needle`.
std::size_t count_lines_with(const std::string& text, const std::string& needle) {
  std::size_t n = 0, at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    n += text.substr(at, end - at).find(needle) != std::string::npos;
    at = end + 1;
  }
  return n;
}

// " word ": the word alone, spaces either side.
std::string spaced(const char* word) {
  std::string s = " ";
  s += word;
  s += ' ';
  return s;
}

TEST_F(Cli, BareCommandListsTheCommandsWithAnExample) {
  const CliRun r = run("");
  EXPECT_EQ(r.status, 0) << r.out;
  for (const char* command :
       {"generate", "info", "fit", "decode", "eval", "compare", "render", "tile", "sweep"})
    EXPECT_NE(r.out.find("\n  " + std::string(command) + " "), std::string::npos)
        << command << ": " << r.out;
  EXPECT_NE(r.out.find("Example"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  btfgmm generate -o corduroy32/ && btfgmm fit corduroy32/"),
            std::string::npos)
      << r.out;
}

TEST_F(Cli, GenerateHelpListsEveryMaterialAndQuietIsQuiet) {
  CliRun r = run("generate --help");
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* m : {"corduroy", "knit", "bumps", "leather"})
    EXPECT_NE(r.out.find(spaced(m)), std::string::npos) << m << ": " << r.out;
  r = run(std::string("generate --size 8 -q ") + kSmall + " -o " + p("btf"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out, "");
  EXPECT_TRUE(fs::exists(p("btf/tv000_pv000/tl000_pl000_tv000_pv000.png")));
}

TEST_F(Cli, EvalLabelsItsValuesAndSaysWhatXAndYAre) {
  CliRun r = run("eval --help");
  EXPECT_NE(r.out.find("integers are pixel centres"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0 the tile's first column"), std::string::npos) << r.out;
  r = run(std::string("generate --size 8 ") + kSmall + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("fit " + p("btf") + " -M 3 --iterations 1 -q -o " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("eval " + p("m.btfgmm") + " --x 3 --y 2 --light 30,90 --view 0,0");
  ASSERT_EQ(r.status, 0) << r.out;
  double red = 0, green = 0, blue = 0;
  char units[64] = {};
  ASSERT_EQ(
      std::sscanf(r.out.c_str(), "R %lf  G %lf  B %lf  (%63[^)])", &red, &green, &blue, units), 4)
      << r.out;
  EXPECT_STREQ(units, "levels of 0-255");
  r = run("eval " + p("m.btfgmm") + " --x 3 --y 2 --light 30,90 --view 0,0 --json");
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["rgb"][0].get<double>(), red, 1e-4);
  EXPECT_NEAR(j["rgb"][2].get<double>(), blue, 1e-4);
  EXPECT_EQ(j["units"], "levels");
}

// decode, eval and compare with --device gpu (lavapipe in CI) beside --device cpu: the same
// figures within a thousandth of a level (the mixture's and the neural BTF's); a method
// without kernels is refused there.
TEST_F(Cli, DecodeEvalAndCompareOnTheGpuGiveTheCpusFigures) {
  CliRun r = run(std::string("generate --size 8 ") + kSmall + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("fit " + p("btf") + " -M 6 --iterations 3 --refine-steps 5 -q -o " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string eval =
      "eval " + p("m.btfgmm") + " --x 2.5 --y 9 --light 20,10 --view 33,250 --json";
  r = run(eval + " --device gpu");
  if (r.status != 0 && r.out.find("no Vulkan device") != std::string::npos) {
    const char* ci = std::getenv("CI");
    ASSERT_FALSE(ci && std::string(ci) == "true") << "CI runs the GPU kernels: " << r.out;
    GTEST_SKIP() << r.out;
  }
  ASSERT_EQ(r.status, 0) << r.out;
  const auto gpu = nlohmann::json::parse(r.out);
  r = run(eval + " --device cpu");
  const auto cpu = nlohmann::json::parse(r.out);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(gpu["rgb"][c].get<double>(), cpu["rgb"][c].get<double>(), 1e-3) << r.out;

  r = run("decode " + p("m.btfgmm") + " --device gpu -o " + p("dec"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find(" as 8-bit RGB) on the GPU "), std::string::npos) << r.out;
  const std::string compare = "compare " + p("btf") + " " + p("m.btfgmm");
  r = run(compare + " --device gpu");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("m.btfgmm on the GPU "), std::string::npos) << r.out;
  r = run(compare + " --json -q --device gpu");
  ASSERT_EQ(r.status, 0) << r.out;
  const double gpu_rmse = nlohmann::json::parse(r.out)["rmse"];
  r = run(compare + " --json -q --device cpu");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NEAR(gpu_rmse, nlohmann::json::parse(r.out)["rmse"].get<double>(), 1e-3);

  r = run("fit " + p("btf") + " --method pca-btf --components 2 -q -o " + p("pca.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("eval " + p("pca.btfgmm") + " --x 0 --y 0 --light 0,0 --view 0,0 --device gpu");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("give --device cpu or auto"), std::string::npos) << r.out;
  r = run("eval " + p("pca.btfgmm") + " --x 0 --y 0 --light 0,0 --view 0,0 --device auto");
  EXPECT_EQ(r.status, 0) << r.out;
  // The neural BTF's network runs there too.
  r = run("fit " + p("btf") + " --method neural -M 2 --width 8 --iterations 1 -q -o " +
          p("nn.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string nn =
      "eval " + p("nn.btfgmm") + " --x 2.5 --y 9 --light 20,10 --view 33,250 --json";
  r = run(nn + " --device gpu");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto nn_gpu = nlohmann::json::parse(r.out);
  r = run(nn + " --device cpu");
  const auto nn_cpu = nlohmann::json::parse(r.out);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(nn_gpu["rgb"][c].get<double>(), nn_cpu["rgb"][c].get<double>(), 1e-3) << r.out;
  // And its fit: the file's provenance and the fit's line name the device.
  r = run("fit " + p("btf") + " --method neural -M 2 --width 8 --iterations 1 --device gpu -o " +
          p("nng.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find(" on the GPU "), std::string::npos) << r.out;
  r = run("info " + p("nng.btfgmm"));
  EXPECT_NE(r.out.find(", device "), std::string::npos) << r.out;
  r = run("decode " + p("m.btfgmm") + " --device tpu -o " + p("x"));
  EXPECT_EQ(r.status, 2) << r.out;
}

TEST_F(Cli, InfoJsonPrintsADirectionPairALine) {
  CliRun r = run(std::string("generate --size 8 ") + kSmall + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("info --json " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);  // still valid JSON
  EXPECT_EQ(j["light_directions"].size(), 11u);
  EXPECT_EQ(j["light_directions"][1], nlohmann::json({30.0, 0.0}));
  EXPECT_EQ(count_lines_with(r.out, "    [30.0, 90.0]"), 1u) << r.out;  // a light
  EXPECT_EQ(count_lines_with(r.out, "    [45.0, 72.0]"), 1u) << r.out;  // a view
  // 11 lights and 6 views, a line each, and a line per other field.
  EXPECT_LT(count_lines_with(r.out, ""), 45u) << r.out;
}

TEST_F(Cli, TilePrefersNearSquareTilesAndListsTheBest) {
  CliRun r = run("generate --size 24 --supersample 1 " + std::string(kSmall) + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("tile --help");
  EXPECT_NE(r.out.find("seam error times its aspect ratio"), std::string::npos) << r.out;
  r = run("tile " + p("btf") + " --size 8-12x8-12 --top 4");
  ASSERT_EQ(r.status, 0) << r.out;
  std::vector<std::pair<int, int>> sizes;
  std::vector<double> scores;
  std::size_t at = r.out.find("\n   1  ");
  ASSERT_NE(at, std::string::npos) << r.out;
  for (int k = 1; k <= 4; ++k) {
    int rank = 0, x = 0, y = 0, w = 0, h = 0;
    double score = 0;
    ASSERT_EQ(
        std::sscanf(r.out.c_str() + at + 1, "%d %d,%d,%d,%d %lf", &rank, &x, &y, &w, &h, &score), 6)
        << r.out;
    EXPECT_EQ(rank, k);
    sizes.emplace_back(w, h);
    scores.push_back(score);
    at = r.out.find('\n', at + 1);
  }
  EXPECT_TRUE(std::is_sorted(scores.begin(), scores.end())) << r.out;
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(std::unique(sizes.begin(), sizes.end()), sizes.end()) << "one line a size: " << r.out;
  // The chosen tile (rank 1) is near square: within 1.5 of it.
  r = run("tile " + p("btf") + " --size 8-12x8-12 --json");
  const auto j = nlohmann::json::parse(r.out);
  const double w = j["tile"][2], h = j["tile"][3];
  EXPECT_LE(std::max(w, h) / std::min(w, h), 1.5) << r.out;
  EXPECT_NEAR(j["score"].get<double>(),
              j["seam_error"].get<double>() * std::max(w, h) / std::min(w, h), 1e-9);
}

}  // namespace
