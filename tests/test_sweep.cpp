// The rate-distortion sweep: its settings and results, skipped settings, the Pareto front, the
// log axis of its chart, and `btfgmm sweep` end to end.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "report/svg.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using test::error_of;

const char* kLights = "rings:0/1,30/4";
const char* kViews = "rings:0/1,45/4";

// An 8 x 8 tile of 5 lights x 5 views (1600 samples).
Btf tiny_tile() {
  GenerateConfig g;
  g.material = "knit";
  g.size = 8;
  g.seed = 3;
  g.lights = DirectionSet::parse(kLights);
  g.views = DirectionSet::parse(kViews);
  g.supersample = 1;
  return generate(g);
}

FitOptions components(std::size_t m) {
  FitOptions s;
  s.components = m;
  return s;
}

// The request's option `field` given as `value` on every setting that takes it (as `sweep`'s
// options do).
void give(SweepRequest& r, std::string_view field, const ParameterValue& value) {
  set_parameter(r.options, *find_fit_parameter(field), value);
  if (std::find(r.given.begin(), r.given.end(), field) == r.given.end()) r.given.push_back(field);
}

// gm at M = 2 and 4, then M = 5000 (more than the tile's 1600 samples), 2 EM iterations.
SweepRequest gm_request() {
  SweepRequest r;
  r.methods = {"gm"};
  r.ladders["gm"] = {components(2), components(4), components(5000)};
  give(r, "iterations", std::int64_t(2));
  return r;
}

// Every value of the attribute `name` in `text`.
std::vector<std::string> attribute_values(const std::string& text, const std::string& name) {
  std::vector<std::string> out;
  const std::string key = " " + name + "=\"";
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    const std::size_t begin = at + key.size(), end = text.find('"', begin);
    out.push_back(text.substr(begin, end - begin));
  }
  return out;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(Sweep, FitsTheLadderMeasuresEachModelAndSkipsRefusedSettings) {
  const Btf tile = tiny_tile();
  SweepRequest r = gm_request();
  std::vector<std::string> events;
  r.progress = [&](const SweepProgress& p) {
    EXPECT_EQ(p.count, 3u);
    EXPECT_EQ(p.method, "gm");
    using E = SweepProgress::Event;
    if (p.event == E::kStart) events.push_back(fmt::format("start {}", p.index));
    if (p.event == E::kDone) events.push_back(fmt::format("done {} {}", p.index, p.result->name));
    if (p.event == E::kSkipped) events.push_back(fmt::format("skipped {}", p.index));
  };
  const SweepOutcome s = run_sweep(tile, r);
  EXPECT_EQ(events, (std::vector<std::string>{"start 0", "done 0 gm-M2", "start 1", "done 1 gm-M4",
                                              "start 2", "skipped 2"}));
  EXPECT_EQ(s.total, 3u);
  EXPECT_FALSE(s.stopped);
  ASSERT_EQ(s.models.size(), 2u);
  ASSERT_EQ(s.settings.size(), 2u);
  EXPECT_EQ(s.settings[0], "components 2, iterations 2");
  for (std::size_t k = 0; k < 2; ++k) {
    const ModelComparison& c = s.models[k];
    EXPECT_EQ(c.model->method(), "gm");
    EXPECT_EQ(c.model->size_order(), double(2 * (k + 1)));  // the ladder's sizes, in order
    // The true size of the model file, which holds exactly this model.
    const std::vector<std::uint8_t> bytes = representation_file_bytes(*c.model);
    EXPECT_EQ(c.file_bytes, bytes.size());
    EXPECT_GT(c.fit_seconds, 0.0);
    EXPECT_GT(c.decode_seconds, 0.0);
    // The quality is that of the model decoded against the tile.
    const BtfQuality q =
        measure_quality(tile, c.model->decode(tile.lights(), tile.views(), 8, 8, kDecodeTolerance));
    EXPECT_DOUBLE_EQ(c.quality.rmse, q.rmse);
    EXPECT_DOUBLE_EQ(c.quality.ssim, q.ssim);
  }
  EXPECT_EQ(s.models[0].name, "gm-M2");
  EXPECT_EQ(s.pareto, pareto_front(s.models));
  // The refused setting: recorded with the method's message.
  ASSERT_EQ(s.skipped.size(), 1u);
  EXPECT_EQ(s.skipped[0].method, "gm");
  EXPECT_EQ(s.skipped[0].settings, "components 5000, iterations 2");
  EXPECT_NE(s.skipped[0].message.find("5000"), std::string::npos) << s.skipped[0].message;
  EXPECT_NE(s.skipped[0].message.find("1600 samples"), std::string::npos) << s.skipped[0].message;
}

TEST(Sweep, WritesModelFilesThatLoadAsTheModelsMeasured) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_sweep_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  SweepRequest r = gm_request();
  r.ladders["gm"].pop_back();
  r.model_folder = dir / "models";
  const Btf tile = tiny_tile();
  const SweepOutcome s = run_sweep(tile, r);
  ASSERT_EQ(s.models.size(), 2u);
  for (const ModelComparison& c : s.models) {
    const fs::path file = r.model_folder / (c.name + ".btfgmm");
    ASSERT_TRUE(fs::exists(file)) << file;
    EXPECT_EQ(fs::file_size(file), c.file_bytes);
    std::shared_ptr<const Representation> loaded = load_representation(file);
    EXPECT_EQ(representation_file_bytes(*loaded), representation_file_bytes(*c.model));
    // The sweep measures what the file holds: `compare` of the file gives the same numbers.
    const ModelComparison again = compare_model(tile, loaded, file.string(), c.file_bytes);
    EXPECT_EQ(again.quality.rmse, c.quality.rmse);
    EXPECT_EQ(again.quality.ssim, c.quality.ssim);
  }
  fs::remove_all(dir);
}

// Unless asked, each method is stored as `fit` stores it by default (the mixture compact, the
// others their declared default); an asked encoding applies to every method.
TEST(Sweep, StoresEachMethodAsFitWritesItUnlessAsked) {
  const Btf tile = tiny_tile();
  SweepRequest r;
  r.methods = {"gm", "pca-btf"};
  r.ladders["gm"] = {components(2)};
  r.ladders["pca-btf"] = {components(2)};
  give(r, "iterations", std::int64_t(2));
  for (const std::optional<FactorEncoding> asked :
       {std::optional<FactorEncoding>(), std::optional(FactorEncoding::kF32)}) {
    r.options.precision = asked;
    r.given = {"iterations"};
    if (asked) r.given.push_back("precision");
    const SweepOutcome s = run_sweep(tile, r);
    ASSERT_EQ(s.models.size(), 2u);
    const auto& gm = dynamic_cast<const GaussianMixture&>(*s.models[0].model);
    const auto& pca = dynamic_cast<const PcaBtf&>(*s.models[1].model);
    EXPECT_EQ(gm.model().precision, asked ? Precision::kF32 : Precision::kCompact);
    EXPECT_EQ(pca.encoding(),
              asked ? FactorEncoding::kF32 : default_file_encoding(find_method("pca-btf")));
  }
}

// --iterations applies to the methods that iterate; the others fit as usual (not dropped) and
// are named. A synthesis is measured (its texture statistics) but never on the pixel-wise
// front, and each method has its own colour in the chart.
TEST(Sweep, IterationsDropNoSettingAndASynthesisIsNotOnTheFront) {
  SweepRequest r;
  r.methods = {"gm", "ptm-rf", "gmrf"};
  r.ladders["gm"] = {components(2)};
  FitOptions two_subspaces;
  two_subspaces.clusters = 2;
  two_subspaces.levels = 1;
  r.ladders["gmrf"] = {two_subspaces};
  give(r, "iterations", std::int64_t(2));
  GenerateConfig g;  // ptm-rf needs 6 lights or more, at two elevations
  g.material = "knit";
  g.size = 8;
  g.lights = DirectionSet::parse("rings:0/1,30/3,60/3");
  g.views = DirectionSet::parse(kViews);
  g.supersample = 1;
  const SweepOutcome s = run_sweep(generate(g), r);
  ASSERT_EQ(s.models.size(), 3u) << (s.skipped.empty() ? "" : s.skipped[0].message);
  EXPECT_TRUE(s.skipped.empty());
  EXPECT_EQ(s.not_iterated, (std::vector<std::string>{"ptm-rf", "gmrf"}));
  EXPECT_EQ(s.models[1].model->method(), "ptm-rf");
  ASSERT_TRUE(s.models[2].model->synthesises());
  ASSERT_TRUE(s.models[2].texture.has_value());
  EXPECT_GT(s.models[2].texture->data_deviation[0], 0.0);
  EXPECT_FALSE(s.pareto[2]);
  EXPECT_FALSE(s.models[0].texture.has_value());
  const Chart c = rate_distortion_chart(s.models);
  std::vector<std::string> colours;
  for (const ChartSeries& series : c.series)
    if (series.line && series.label.starts_with("g")) colours.push_back(series.colour);
  ASSERT_EQ(colours.size(), 2u);  // gm's and gmrf's curves
  EXPECT_NE(colours[0], colours[1]);
}

TEST(Sweep, ChecksTheRequestAndStopsOnTheFlag) {
  const Btf tile = tiny_tile();
  SweepRequest r;
  r.methods = {"gn"};
  EXPECT_NE(error_of([&] { run_sweep(tile, r); }).find("did you mean 'gm'"), std::string::npos);
  r.methods = {"gm", "gm"};
  EXPECT_NE(error_of([&] { run_sweep(tile, r); }).find("named twice"), std::string::npos);
  r.methods = {"gm"};
  r.ladders["nothing"] = {};
  EXPECT_NE(error_of([&] { run_sweep(tile, r); }).find("unknown method 'nothing'"),
            std::string::npos);
  // Stopped before the first fit: the method's own ladder counted, nothing fitted.
  r.ladders.clear();
  std::atomic<bool> stop{true};
  r.stop = &stop;
  const SweepOutcome s = run_sweep(tile, r);
  EXPECT_TRUE(s.stopped);
  EXPECT_TRUE(s.models.empty());
  EXPECT_EQ(s.total, find_method("gm").ladder(ModelFrame::of(tile)).size());
  EXPECT_EQ(settings_text(FitOptions{}), "the method's defaults");
  FitOptions neural;  // the network's shape named: two rungs may differ in it alone
  neural.components = 4;
  neural.width = 32;
  neural.depth = 2;
  EXPECT_EQ(settings_text(neural), "components 4, width 32, depth 2");
}

// The refinement's bounds apply to the mixture alone: in epochs its models are the same with
// any number of threads (so on any machine at any load), and the settings and provenance
// say so. Bounds out of range, or with no mixture swept, are refused before any fit.
TEST(Sweep, RefinementBoundsApplyToTheMixtureAndMakeItsModelsReproducible) {
  const Btf tile = tiny_tile();
  SweepRequest r;
  r.methods = {"gm", "pca-btf"};
  r.ladders["gm"] = {components(4)};
  r.ladders["pca-btf"] = {components(2)};
  give(r, "iterations", std::int64_t(2));
  give(r, "refine_epochs", std::int64_t(2));
  std::vector<std::vector<std::uint8_t>> payloads;
  for (int threads : {1, 2}) {
    give(r, "threads", std::int64_t(threads));
    const SweepOutcome s = run_sweep(tile, r);
    ASSERT_EQ(s.models.size(), 2u) << (s.skipped.empty() ? "" : s.skipped[0].message);
    EXPECT_EQ(s.settings[0], "components 4, iterations 2, refine epochs 2");
    EXPECT_EQ(s.settings[1], "components 2");
    const auto& gm = dynamic_cast<const GaussianMixture&>(*s.models[0].model);
    const auto& settings = gm.provenance().fit.settings;
    EXPECT_NE(std::find(settings.begin(), settings.end(),
                        std::pair<std::string, std::string>{"refine epochs", "2"}),
              settings.end());
    payloads.push_back(gm.payload());
  }
  EXPECT_EQ(payloads[0], payloads[1]);
  r.options.refine_seconds = -1;  // set past the one check a front end makes
  EXPECT_NE(error_of([&] {
              check_fit_options(r.options, std::vector<std::string_view>{"refine_seconds"},
                                FitRoute::kSweep);
            }).find("--refine-seconds -1: out of range; give"),
            std::string::npos);
  r.options.refine_seconds = 0;
  give(r, "refine_epochs", std::int64_t(3));
  r.methods = {"pca-btf"};
  r.ladders.erase("gm");
  EXPECT_NE(error_of([&] { run_sweep(tile, r); }).find("which is not swept"), std::string::npos);
}

TEST(Sweep, ParetoFrontKeepsTheHighestPsnrAtEachRatioOrMore) {
  const double nan = std::numeric_limits<double>::quiet_NaN(),
               inf = std::numeric_limits<double>::infinity();
  const std::vector<std::array<double, 2>> points = {
      {10, 30},   // on it: nothing compresses more with 30 dB or more
      {20, 28},   // on it
      {15, 27},   // below (20, 28)
      {20, 28},   // equal to a point on it: on it too
      {5, 29},    // below (10, 30)
      {40, 20},   // on it: the highest ratio
      {nan, 50},  // not a point
      {40, 19},   // below (40, 20): same ratio, lower PSNR
      {2, inf},   // exact: on it
  };
  EXPECT_EQ(pareto_front(points),
            (std::vector<bool>{true, true, false, true, false, true, false, false, true}));
  EXPECT_TRUE(pareto_front(std::span<const std::array<double, 2>>{}).empty());
}

TEST(Sweep, LogAxisTicksAreDecades) {
  svg::Axis a = svg::make_log_axis(3, 4000);
  EXPECT_TRUE(a.log);
  EXPECT_EQ(a.lo, 1.0);
  EXPECT_EQ(a.hi, 10000.0);
  EXPECT_EQ(svg::axis_ticks(a), (std::vector<double>{1, 10, 100, 1000, 10000}));
  EXPECT_EQ(svg::axis_tick_text(a, 1000), "1000");
  // Within two decades: 1, 2 and 5 times each decade, from and to the nearest of them.
  a = svg::make_log_axis(7.3, 21.9);
  EXPECT_EQ(a.lo, 5.0);
  EXPECT_EQ(a.hi, 50.0);
  EXPECT_EQ(svg::axis_ticks(a), (std::vector<double>{5, 10, 20, 50}));
  // Over ten decades, every second one.
  a = svg::make_log_axis(0.02, 3e7);
  const std::vector<double> ticks = svg::axis_ticks(a);
  ASSERT_EQ(ticks.size(), 6u);
  for (std::size_t k = 0; k < ticks.size(); ++k)
    EXPECT_DOUBLE_EQ(ticks[k], std::pow(10.0, -2.0 + 2.0 * double(k)));
  EXPECT_EQ(svg::axis_tick_text(a, 0.01), "0.01");
}

TEST(Sweep, RateDistortionChartHasALogAxisAndACurvePerMethod) {
  SweepRequest r = gm_request();
  r.ladders["gm"] = {components(2), components(6), components(3)};
  const SweepOutcome s = run_sweep(tiny_tile(), r);
  ASSERT_EQ(s.models.size(), 3u);
  const Chart c = rate_distortion_chart(s.models);
  EXPECT_TRUE(c.x_log);
  // The front, gm's curve, gm's paper's-count markers, the legend's entry for them.
  ASSERT_EQ(c.series.size(), 4u);
  const auto& curve = c.series[1].points;
  ASSERT_EQ(curve.size(), 3u);
  for (std::size_t k = 1; k < curve.size(); ++k) EXPECT_LT(curve[k - 1][0], curve[k][0]);
  const std::string svg = svg_chart(c);
  EXPECT_NE(svg.find("data-x-scale=\"log\""), std::string::npos);
  EXPECT_EQ(count_of(svg, "<polyline"), 2u);  // the front and one curve (one method)
  for (const std::string& pts : attribute_values(svg, "points")) {
    std::istringstream in(pts);
    std::string xy;
    while (in >> xy) {
      const double x = std::stod(xy.substr(0, xy.find(',')));
      EXPECT_GE(x, 66.0);
      EXPECT_LE(x, c.width - 30.0);
    }
  }
  // Every label within the canvas: a centred one's half width (6.5 px a character at the
  // chart's 11 px font, an upper bound) on either side of its x, a right-aligned one's width
  // to its left.
  for (std::size_t at = svg.find("<text x=\""); at != std::string::npos;
       at = svg.find("<text x=\"", at + 1)) {
    const double x = std::stod(svg.substr(at + 9));
    const std::size_t open = svg.find('>', at), close = svg.find("</text>", at);
    const double width = 6.5 * double(close - open - 1);
    const std::string tag = svg.substr(at, open - at);
    if (tag.find("text-anchor=\"middle\"") != std::string::npos) {
      EXPECT_GE(x - width / 2, 0.0) << svg.substr(at, close - at);
      EXPECT_LE(x + width / 2, c.width) << svg.substr(at, close - at);
    } else if (tag.find("text-anchor=\"end\"") != std::string::npos) {
      EXPECT_GE(x - width, 0.0) << svg.substr(at, close - at);
    }
  }
}

TEST(Sweep, ReportOfSeveralMethodsHasACurveEachAndTheirImages) {
  SweepRequest r;
  r.methods = {"gm", "pca-btf"};
  r.ladders["gm"] = {components(2), components(4)};
  r.ladders["pca-btf"] = {components(1), components(3)};
  give(r, "iterations", std::int64_t(2));
  const SweepOutcome s = run_sweep(tiny_tile(), r);
  ASSERT_EQ(s.models.size(), 4u);
  EXPECT_EQ(s.models[2].name, "pca-btf-c1");
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_sweep_report_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  write_report(dir, "tiny", s.models);  // as `compare` writes it
  const std::string html = [&] {
    std::ifstream in(dir / "index.html");
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }();
  const std::size_t at = html.find("data-x-scale=\"log\"");
  ASSERT_NE(at, std::string::npos);
  const std::string chart = html.substr(at, html.find("</svg>", at) - at);
  EXPECT_EQ(count_of(chart, "<polyline"), 3u);  // the front, gm, pca-btf
  // The Pareto column marks as many models as pareto_front.
  std::size_t on_front = 0;
  for (bool b : s.pareto) on_front += b;
  EXPECT_EQ(count_of(html, "&#9733;</td>"), on_front);
  // The frontal image: the original and one model per method.
  EXPECT_NE(html.find("One image decoded by each method"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "methods_original.png"));
  EXPECT_TRUE(fs::exists(dir / "methods_2.png"));
  EXPECT_FALSE(fs::exists(dir / "methods_3.png"));
  fs::remove_all(dir);
}

// ---- btfgmm sweep ------------------------------------------------------------------------

using test::CliRun;

CliRun run(const std::string& args) {
  return test::run_cli(args, "sweep_test");
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// A new, empty folder named for `tag` and this process, with the 8 x 8 knit of tiny_tile's
// directions written by `generate` into DIR/btf.
fs::path folder_with_generated_btf(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / (tag + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const CliRun r =
      run(fmt::format("generate --material knit --size 8 --seed 3 --lights {} --views {} "
                      "-o {}/btf",
                      kLights, kViews, dir.string()));
  EXPECT_EQ(r.status, 0) << r.err;
  return dir;
}

TEST(SweepCli, WritesTheTableJsonAndReport) {
  const fs::path dir = folder_with_generated_btf("btfgmm_sweep_cli_");
  ASSERT_TRUE(fs::exists(dir / "btf"));
  const std::string d = dir.string();
  CliRun r;
  const std::string sweep = "sweep " + d + "/btf --tile 0,0,8,8 --iterations 2 ";
  r = run(sweep + "--methods gm --components 2,4,5000 --keep-models -o " + d + "/out");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* word : {"C.R. file", "PSNR dB", "decode s", "Pareto", "gm", "M = 4", "skipped"})
    EXPECT_NE(r.out.find(word), std::string::npos) << word << "\n" << r.out;
  EXPECT_NE(r.err.find("[3/3] gm components 5000"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(slurp(dir / "out/sweep.json"));
  ASSERT_EQ(j["models"].size(), 2u);
  EXPECT_EQ(j["models"][1]["size"], "M = 4");
  EXPECT_EQ(j["models"][1]["file_bytes"], fs::file_size(dir / "out/models/gm-M4.btfgmm"));
  EXPECT_TRUE(j["models"][0].contains("pareto"));
  ASSERT_EQ(j["skipped"].size(), 1u);
  EXPECT_EQ(j["tile"], nlohmann::json({0, 0, 8, 8}));
  // The report: the rate-distortion chart on a log axis, one curve per method and the front.
  const std::string html = slurp(dir / "out/index.html");
  const std::size_t at = html.find("data-x-scale=\"log\"");
  ASSERT_NE(at, std::string::npos);
  const std::string chart = html.substr(at, html.find("</svg>", at) - at);
  EXPECT_EQ(count_of(chart, "<polyline"), 2u);
  EXPECT_NE(html.find("btfgmm sweep"), std::string::npos);
  EXPECT_NE(html.find("One image decoded by each method"), std::string::npos);
  EXPECT_NE(html.find("Not fitted"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "out/methods_original.png"));

  // The sweep measures the file `fit` writes by default for the same setting: the same
  // encoding and payload, byte for byte, and the same size but for the provenance's text
  // (the input's path, the times).
  r = run(sweep + "--methods pca-btf --components 2 --keep-models -o " + d + "/pca");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string fit = "fit " + d + "/btf --tile 0,0,8,8 ";
  for (const auto& [args, swept] :
       {std::pair<std::string, std::string>{"-M 4 --iterations 2", "out/models/gm-M4.btfgmm"},
        {"--method pca-btf --components 2", "pca/models/pca-btf-c2.btfgmm"}}) {
    r = run(fit + args + " -o " + d + "/fitted.btfgmm --overwrite");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto fitted = load_representation(dir / "fitted.btfgmm");
    const auto from_sweep = load_representation(dir / swept);
    EXPECT_EQ(fitted->encoding(), from_sweep->encoding()) << args;
    EXPECT_EQ(fitted->file_flags(), from_sweep->file_flags()) << args;
    EXPECT_EQ(fitted->payload(), from_sweep->payload()) << args;
    // The rest is the provenance: the command's fit logs more of its run.
    const double fitted_bytes = double(fs::file_size(dir / "fitted.btfgmm")),
                 swept_bytes = double(fs::file_size(dir / swept));
    EXPECT_NEAR(swept_bytes, fitted_bytes, 512.0) << args;
  }

  // Errors: an unknown method (with the nearest name), no method, a folder in use.
  r = run(sweep + "--methods gm,gn -o " + d + "/other");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--methods: unknown method 'gn' (did you mean 'gm'?)"), std::string::npos)
      << r.err;
  r = run(sweep + "--methods , -o " + d + "/other");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("names no method"), std::string::npos) << r.err;
  r = run(sweep + "-o " + d + "/out");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "other"));
  fs::remove_all(dir);
}

// sweep --refine-epochs measures the file fit --refine-epochs writes (the same payload), and
// refuses it with no mixture swept.
TEST(SweepCli, RefinementBoundInEpochsMeasuresTheFileFitWrites) {
  const fs::path dir = folder_with_generated_btf("btfgmm_sweep_epochs_");
  ASSERT_TRUE(fs::exists(dir / "btf"));
  const std::string d = dir.string();
  CliRun r;
  const std::string sweep = "sweep " + d + "/btf --tile 0,0,8,8 --iterations 2 --refine-epochs 1 ";
  r = run(sweep + "--methods gm --components 4 --keep-models -o " + d + "/out");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("gm components 4, iterations 2, refine epochs 1"), std::string::npos)
      << r.err;
  r = run("fit " + d + "/btf --tile 0,0,8,8 -M 4 --iterations 2 --refine-epochs 1 -o " + d +
          "/fitted.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(load_representation(dir / "fitted.btfgmm")->payload(),
            load_representation(dir / "out/models/gm-M4.btfgmm")->payload());
  r = run("info " + d + "/out/models/gm-M4.btfgmm");
  EXPECT_NE(r.out.find("refine epochs 1"), std::string::npos) << r.out;
  r = run(sweep + "--methods pca-btf -o " + d + "/pca");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--refine-epochs bound the refinement of the Gaussian mixture (gm), "
                       "which is not swept"),
            std::string::npos)
      << r.err;
  r = run(sweep + "--refine-seconds 0.1 -o " + d + "/other");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--refine-seconds 0.1: out of range"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "other"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
