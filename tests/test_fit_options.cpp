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
#include "btfgmm/measure/budget.hpp"
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

// A fit's options are checked once, by its front end (the command, Python: check_fit_options
// before any work): the fit behind it, a sweep's settings and a budget's candidates check
// nothing again.
TEST_F(FitOptionsTest, OptionsAreCheckedOncePerFit) {
  FitOptions pca;
  pca.method = "pca-btf";
  pca.components = 2;
  FitOptions gm;
  gm.components = 3;
  gm.iterations = 2;
  gm.refine_steps = 5;
  gm.threads = 1;
  const std::uint64_t before = fit_option_checks();
  for (const FitOptions& o : {pca, gm}) {
    check_fit_options(o, given_fields(o), FitRoute::kNew);
    ASSERT_NE(fit_representation(o, p("btf"), nullptr, {}), nullptr);
  }
  EXPECT_EQ(fit_option_checks() - before, 2u);
  const Btf tile = BtfSource::open(p("btf")).load({.x = 0, .y = 0, .width = 8, .height = 8});
  SweepRequest q;
  q.methods = {"gm", "pca-btf"};
  FitOptions two, three;
  two.components = 2;
  three.components = 3;
  q.ladders["gm"] = {two, three};
  q.options.iterations = 2;
  q.options.threads = 1;
  q.given = given_fields(q.options);
  check_fit_options(q.options, q.given, FitRoute::kSweep);
  const SweepOutcome swept = run_sweep(tile, q);
  EXPECT_GE(swept.models.size(), 3u);
  EXPECT_EQ(swept.models[0].model->provenance().fit.iterations.size(), 2u);  // `given` applied
  BudgetRequest b;
  b.budget = 100000;
  b.methods = {"pca-btf"};
  b.options.seed = 3;
  b.given = given_fields(b.options);
  check_fit_options(b.options, b.given, FitRoute::kBudget, "budget");
  const BudgetChoice chosen = choose_within_budget(tile, b);
  EXPECT_GE(chosen.candidates.size(), 2u);
  EXPECT_EQ(fit_option_checks() - before, 4u);  // one a fit, a sweep, a budget
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
  f16.precision = FactorEncoding::kF16;
  EXPECT_EQ(mixture_fit_request(f16, "in", "out").precision, Precision::kF16);
  EXPECT_EQ(default_file_encoding(find_method("pca-btf")), FactorEncoding::kCompact);
  // The defaults the declarations state are the fit's own.
  const MethodInfo& gm = find_method("gm");
  EXPECT_EQ(method_parameter(gm, "components")->default_text, std::to_string(r.config.components));
  EXPECT_EQ(method_parameter(gm, "iterations")->default_text,
            std::to_string(r.config.em.max_iterations));
  EXPECT_EQ(method_parameter(gm, "objective")->default_text, "prediction");
  EXPECT_EQ(method_parameter(gm, "precision")->default_text, "compact");
  for (const MethodInfo& m : all_methods()) {
    ASSERT_NE(method_parameter(m, "precision"), nullptr) << m.name;  // every method stores
    EXPECT_EQ(to_string(default_file_encoding(m)),
              m.name == "3d-car" || m.name == "2d-car" || m.name == "gmrf" ? "f16" : "compact")
        << m.name;
  }
  EXPECT_EQ(method_parameter(find_method("plm-rf"), "degree")->default_text,
            std::to_string(PlmRf::kDefaultDegree));
}

// The error of the one check of `o` (the fields it sets given), for a new fit.
std::string check_error(const FitOptions& o) {
  return test::error_of([&] { check_fit_options(o, given_fields(o), FitRoute::kNew); });
}

TEST(FitOptions, OptionsThatCannotApplyAreErrors) {
  const auto has = [](const std::string& error, const char* text) {
    return error.find(text) != std::string::npos;
  };
  FitOptions o;
  EXPECT_TRUE(has(test::error_of([&] {
                    set_parameter(o, *find_fit_parameter("precision"), std::string("f8"));
                  }),
                  "--precision f8: not one of its choices; give compact, f32, f16 or q8"));
  o = {};
  o.clusters = 4;
  EXPECT_TRUE(has(check_error(o),
                  "--clusters cannot apply to --method gm, which does not take "
                  "it (--clusters is taken by lpca, 3d-car, 2d-car, gmrf)"));
  o = {};
  o.method = "lpca";
  o.epsilon = 0.01;
  EXPECT_TRUE(has(check_error(o),
                  "--epsilon cannot apply to --method lpca: they belong to the "
                  "Gaussian mixture's fit"));
  o = {};
  o.method = "pca-btf";
  o.refine_steps = 50;
  EXPECT_TRUE(has(check_error(o), "--refine-steps cannot apply to --method pca-btf"));
  o.method = "gm";
  o.objective = "likelihood";
  EXPECT_TRUE(has(check_error(o), "--refine-steps applies to the objective prediction only"));
  o = {};
  o.refine_steps = -3;
  EXPECT_EQ(check_error(o),
            "--refine-steps -3: out of range; give a whole number from 1 to 100000");
  o = {};
  o.method = "pca-btff";
  EXPECT_TRUE(has(check_error(o), "unknown method 'pca-btff' (did you mean 'pca-btf'?)"));
}

// `o`'s field of `p` set to `x` without the check (a value a C++ caller could set).
void set_unchecked(FitOptions& o, const FitParameter& p, double x) {
  std::visit(
      [&](auto member) {
        using M = decltype(member);
        if constexpr (std::is_same_v<M, std::size_t FitOptions::*>)
          o.*member = std::size_t(x);
        else if constexpr (std::is_same_v<M, int FitOptions::*>)
          o.*member = int(x);
        else if constexpr (std::is_same_v<M, double FitOptions::*> ||
                           std::is_same_v<M, std::optional<double> FitOptions::*>)
          o.*member = x;
      },
      p.member);
}

// Every number a declaration bounds is refused just outside its range and taken at its ends:
// as a front end reads it (set_parameter, the command's and Python's way) and by the one check
// of a new fit, a sweep and a budget wherever the field may be given, with one message.
TEST(FitOptions, EveryRangeIsRefusedTheSameOnEveryRoute) {
  int refused = 0;
  for (const FitParameter* p : fit_parameters()) {
    if (std::holds_alternative<std::monostate>(p->member) || !p->is_number()) continue;
    const std::vector<std::string_view> takers = methods_taking(p->field);
    FitOptions base;
    if (!takers.empty()) base.method = std::string(takers[0]);
    const auto value = [p](double x) {
      return p->type == ParameterType::kReal ? ParameterValue(x) : ParameterValue(std::int64_t(x));
    };
    for (const double bad : {p->min - 1, p->max + 1}) {
      if (bad >= p->max && p->max > 1e15) continue;  // past what a double tells from the max
      FitOptions o = base;
      const std::string e = test::error_of([&] { set_parameter(o, *p, value(bad)); });
      EXPECT_EQ(
          e.rfind(test::command_line_option(p->field) + " " + value_text(value(bad)) + ": ", 0), 0u)
          << p->field << " " << bad << ": " << e;
      ++refused;
      if (bad < p->max) continue;  // below: 0, the default, for most
      set_unchecked(o, *p, bad);
      for (const FitRoute route : {FitRoute::kNew, FitRoute::kSweep, FitRoute::kBudget}) {
        if (!p->takes_route(route)) continue;
        EXPECT_EQ(test::error_of([&] {
                    check_fit_options(o, std::vector<std::string_view>{p->field}, route, "budget");
                  }),
                  e)
            << p->field;
      }
    }
    for (const FitRoute route : {FitRoute::kNew, FitRoute::kSweep, FitRoute::kBudget}) {
      if (!p->takes_route(route)) continue;
      FitOptions o = base;
      EXPECT_NO_THROW(set_parameter(o, *p, value(p->max)));
      EXPECT_NO_THROW(
          check_fit_options(o, std::vector<std::string_view>{p->field}, route, "budget"))
          << p->field;
    }
  }
  EXPECT_GE(refused, 20);
  FitOptions o;
  EXPECT_EQ(test::error_of([&] { set_parameter(o, *find_fit_parameter("epsilon"), 0.5 * 3); }),
            "--epsilon 1.5: out of range; give a number from 0 to 1");
  EXPECT_EQ(test::error_of([&] { set_parameter(o, *find_fit_parameter("components"), 2.5); }),
            "--components 2.5: not a whole number; give a whole number from 1 to 100000");
  EXPECT_EQ(test::error_of([&] {
              set_parameter(o, *find_fit_parameter("iterations"),
                            parse_parameter(*find_fit_parameter("iterations"), "ten"));
            }),
            "--iterations ten: not a number; give a whole number from 1 to 100000");
}

// Each method declares a field once; the declarations of a field agree on its type and range
// (so that one option spells it), and each has its routes and help.
TEST(FitOptions, TheDeclarationsAgree) {
  for (const MethodInfo& m : all_methods()) {
    std::vector<std::string_view> fields;
    for (const FitParameter& p : m.parameters) {
      EXPECT_EQ(std::count(fields.begin(), fields.end(), p.field), 0) << m.name << " " << p.field;
      fields.push_back(p.field);
      const FitParameter& first = *find_fit_parameter(p.field);
      EXPECT_EQ(p.type, first.type) << p.field;
      EXPECT_EQ(p.min, first.min) << p.field;
      EXPECT_EQ(p.max, first.max) << p.field;
      EXPECT_NE(p.routes, 0u) << p.field;
      EXPECT_LE(p.min, p.max) << p.field;
      const bool held = !std::holds_alternative<std::monostate>(p.member);
      EXPECT_TRUE(!held || !p.help.empty()) << p.field;
    }
  }
  EXPECT_EQ(methods_taking("levels"), (std::vector<std::string_view>{"3d-car", "2d-car", "gmrf"}));
  EXPECT_TRUE(methods_taking("seed").empty());  // a common field
  EXPECT_EQ(find_fit_parameter("refine_steps")->max, kMaxRefineSteps);
  EXPECT_EQ(parameter_help("degree"),
            "plm-rf: the degree l of the per-image polynomial (default 4)");
  EXPECT_EQ(find_fit_parameter("no_such_field"), nullptr);
}

// One check for every route: the options refused are named in the declarations' order.
TEST(FitOptions, OneCheckRefusesWhatCannotApply) {
  const auto refused = [](std::vector<std::string_view> given, std::string_view method,
                          FitRoute route, std::string_view source) {
    FitOptions o;
    o.method = std::string(method);
    return test::error_of([&] { check_fit_options(o, given, route, source); });
  };
  EXPECT_EQ(refused({"tile", "seed", "iterations"}, "gm", FitRoute::kResume, "c.ckpt"),
            "--tile, --seed cannot apply with --resume: the fit goes on with the input, tile, "
            "components, seed, precision and output its checkpoint 'c.ckpt' holds; leave them "
            "out");
  EXPECT_EQ(refused({"log"}, "lpca", FitRoute::kNew, ""),
            "--log cannot apply to --method lpca: they belong to the Gaussian mixture's fit "
            "(--method gm) only; leave it out");
  EXPECT_NE(refused({"levels", "iterations"}, "gm", FitRoute::kBudget, "ratio")
                .find("--levels cannot apply with --ratio: it chooses the method"),
            std::string::npos);
  EXPECT_NE(
      refused({"epsilon"}, "gm", FitRoute::kSweep, "").find("--epsilon cannot apply to a sweep"),
      std::string::npos);
  FitOptions gm;
  EXPECT_NO_THROW(check_fit_options(gm,
                                    std::vector<std::string_view>{"iterations", "epsilon", "log"},
                                    FitRoute::kContinue, "m.btfgmm"));
  FitOptions o;
  o.method = "lpca";
  o.clusters = 3;
  o.epsilon = 0.1;
  EXPECT_EQ(given_fields(o), (std::vector<std::string_view>{"method", "epsilon", "clusters"}));
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

}  // namespace
}  // namespace btfgmm
