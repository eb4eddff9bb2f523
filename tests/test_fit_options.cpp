// The fit's options and defaults in the library (methods/fit_options.hpp), shared by the
// command and the Python module, and the checks of a model against data on disk
// (measure/compare_data.hpp): fit_representation fits what run_fit writes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

class FitOptionsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("btfgmm_fit_options_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    GenerateConfig g;
    g.size = 8;
    g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
    g.views = DirectionSet::parse("rings:0/1,45/5");
    write_utia(generate(g), dir_ / "btf");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string p(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// Everything a file holds but the provenance's times: the payload, the data and settings
// recorded, and the EM log's L and components.
void expect_same_but_times(const Representation& a, const Representation& b) {
  EXPECT_EQ(a.payload(), b.payload());
  const Provenance &pa = a.provenance(), &pb = b.provenance();
  EXPECT_TRUE(pa.recorded && pb.recorded);
  EXPECT_EQ(pa.data.source.name, pb.data.source.name);
  EXPECT_EQ(pa.data.content_hash, pb.data.content_hash);
  EXPECT_EQ(pa.fit.settings, pb.fit.settings);
  ASSERT_EQ(pa.fit.iterations.size(), pb.fit.iterations.size());
  for (std::size_t i = 0; i < pa.fit.iterations.size(); ++i) {
    EXPECT_EQ(pa.fit.iterations[i].log_likelihood, pb.fit.iterations[i].log_likelihood);
    EXPECT_EQ(pa.fit.iterations[i].components, pb.fit.iterations[i].components);
  }
}

TEST_F(FitOptionsTest, MixtureFittedInMemoryIsTheModelRunFitWrites) {
  FitOptions o;
  o.components = 5;
  o.iterations = 3;
  o.seed = 2;
  o.threads = 1;
  FitRequest r = mixture_fit_request(o, p("btf"), p("m.btfgmm"));
  r.tile = {.x = 1, .y = 0, .width = 6, .height = 5};
  run_fit(r);
  const auto written = load_representation(p("m.btfgmm"));
  const auto in_memory =
      fit_representation(o, p("btf"), nullptr, {.x = 1, .y = 0, .width = 6, .height = 5});
  ASSERT_EQ(in_memory->method(), "gm");
  expect_same_but_times(*written, *in_memory);
  EXPECT_EQ(written->provenance().fit.iterations.size(), 3u);
  EXPECT_EQ(representation_file_bytes(*in_memory).size(), fs::file_size(p("m.btfgmm")));
}

TEST_F(FitOptionsTest, AnotherMethodRecordsWhatTheCommandRecords) {
  FitOptions o;
  o.method = "pca-btf";
  o.components = 3;
  const auto a = fit_representation(o, p("btf"), nullptr, {});
  const auto b =
      fit_representation(o, p("btf"), std::make_shared<const BtfSource>(BtfSource::open(p("btf"))),
                         {.x = 0, .y = 0, .width = 8, .height = 8});
  expect_same_but_times(*a, *b);
  EXPECT_EQ(a->frame().width, 8);
  const auto& s = a->provenance().fit.settings;
  ASSERT_GE(s.size(), 3u);
  EXPECT_EQ(s[0], (std::pair<std::string, std::string>{"method", "pca-btf"}));
  EXPECT_EQ(s[1], (std::pair<std::string, std::string>{"components", "3"}));
}

TEST(FitOptions, DefaultsAreTheCommands) {
  const FitRequest r = mixture_fit_request({}, "in", "out");
  EXPECT_EQ(r.config.components, 600u);
  EXPECT_EQ(r.config.em.max_iterations, 40);
  EXPECT_EQ(r.config.em.epsilon, 0.0);
  EXPECT_EQ(r.precision, Precision::kCompact);
  EXPECT_EQ(r.config.objective, FitObjective::kPrediction);
  EXPECT_EQ(r.config.refinement_steps, 0);  // as many as the fit affords
  FitOptions steps;
  steps.refine_steps = 1000;
  EXPECT_EQ(mixture_fit_request(steps, "in", "out").config.refinement_steps, 1000);
  FitOptions f16;
  f16.precision = "f16";
  EXPECT_EQ(mixture_fit_request(f16, "in", "out").precision, Precision::kF16);
  EXPECT_EQ(method_settings({}, find_method("pca-btf")).encoding, FactorEncoding::kCompact);
  EXPECT_EQ(method_settings({}, find_method("pca-btf")).components, 0u);  // the method's own
}

// The error of the mixture's fit request for `o`, and of `method`'s settings.
std::string mixture_error(const FitOptions& o) {
  return test::error_of([&] { mixture_fit_request(o, "in", "out"); });
}
std::string settings_error(const FitOptions& o, const char* method) {
  return test::error_of([&] { method_settings(o, find_method(method)); });
}

TEST(FitOptions, OptionsThatCannotApplyAreErrors) {
  const auto has = [](const std::string& error, const char* text) {
    return error.find(text) != std::string::npos;
  };
  FitOptions o;
  o.precision = "f8";
  EXPECT_TRUE(has(mixture_error(o), "--precision 'f8': the Gaussian mixture stores compact"));
  o = {};
  o.clusters = 4;
  EXPECT_TRUE(has(mixture_error(o), "--clusters applies to --method lpca only"));
  o = {};
  o.epsilon = 0.01;
  EXPECT_TRUE(has(settings_error(o, "lpca"), "--epsilon cannot apply to --method lpca"));
  o = {};
  o.refine_steps = 50;
  EXPECT_TRUE(has(settings_error(o, "pca-btf"), "--refine-steps cannot apply to --method pca-btf"));
  o.objective = "likelihood";
  EXPECT_TRUE(has(mixture_error(o), "--refine-steps applies to the objective prediction only"));
  o = {};
  o.refine_steps = -3;
  EXPECT_TRUE(has(mixture_error(o), "--refine-steps -3: give 1 to 100000 Adam steps"));
}

TEST(FitOptions, HemisphereDirectionsWrapPhiAndRefuseThetaOffTheHemisphere) {
  EXPECT_EQ(hemisphere_direction(30, -30, "light", "").phi_deg, 330.0);
  EXPECT_EQ(hemisphere_direction(30, 725, "light", "").phi_deg, 5.0);
  EXPECT_EQ(parse_direction("90,360", "--view").phi_deg, 0.0);
  EXPECT_NE(test::error_of([] {
              parse_direction("95,0", "--view");
            }).find("--view '95,0': theta 95 is off the upper hemisphere"),
            std::string::npos);
}

TEST(FitOptions, OtherDataIsRefusedUnlessForced) {
  const DataCheck other{DataMatch::kOtherContent, "other values"};
  EXPECT_NE(test::error_of([&] { refuse_other_data(other, false, "compare"); })
                .find("other values; give the data the model was fitted to, or add --force to "
                      "compare anyway"),
            std::string::npos);
  refuse_other_data(other, true, "compare");
  refuse_other_data({DataMatch::kNotRecorded, "none"}, false, "compare");
}

// The table of the fit's options names only methods the registry knows, gives each option
// one row, and a range where it has one in order.
TEST(FitOptions, TheTableNamesKnownMethodsOnceEach) {
  std::vector<std::string_view> fields;
  for (const FitOptionRule& r : fit_option_rules()) {
    EXPECT_EQ(std::count(fields.begin(), fields.end(), r.field), 0) << r.field;
    fields.push_back(r.field);
    EXPECT_NE(r.routes, 0u) << r.field;
    EXPECT_LE(r.min, r.max) << r.field;
    if (r.methods == "all") continue;
    std::size_t known = 0;
    for (const MethodInfo& m : all_methods()) known += r.takes(m.name);
    EXPECT_EQ(known, std::size_t(std::count(r.methods.begin(), r.methods.end(), ' ') + 1))
        << r.field << ": " << r.methods;
  }
  EXPECT_TRUE(fit_option_rule("levels").takes("gmrf"));
  EXPECT_FALSE(fit_option_rule("levels").takes("gm"));
  EXPECT_FALSE(fit_option_rule("clusters").takes("lpc"));  // whole names only
  EXPECT_EQ(fit_option_rule("refine_steps").max, kMaxRefineSteps);
}

// One check for every route: the options refused are named in the table's order, each once.
TEST(FitOptions, OneCheckRefusesWhatCannotApply) {
  const auto refused = [](std::vector<std::string_view> given, std::string_view method,
                          FitRoute route, std::string_view source) {
    return test::error_of([&] { check_fit_options(given, method, route, source); });
  };
  EXPECT_EQ(refused({"seed", "tile", "iterations"}, "gm", FitRoute::kResume, "c.ckpt"),
            "--tile, --seed cannot apply with --resume: the fit goes on with the input, tile, "
            "components, seed, precision and output its checkpoint 'c.ckpt' holds; leave them "
            "out");
  EXPECT_EQ(refused({"log"}, "lpca", FitRoute::kNew, ""),
            "--log cannot apply to --method lpca: they belong to the Gaussian mixture's fit "
            "(--method gm) only; leave it out");
  EXPECT_NE(refused({"levels", "iterations"}, "gm", FitRoute::kBudget, "ratio")
                .find("--levels cannot apply with --ratio: it chooses the method"),
            std::string::npos);
  EXPECT_NO_THROW(check_fit_options(std::vector<std::string_view>{"iterations", "epsilon", "log"},
                                    "gm", FitRoute::kContinue, "m.btfgmm"));
  FitOptions o;
  o.method = "lpca";
  o.clusters = 3;
  o.epsilon = 0.1;
  EXPECT_EQ(given_fields(o), (std::vector<std::string_view>{"method", "clusters", "epsilon"}));
}

}  // namespace
}  // namespace btfgmm
