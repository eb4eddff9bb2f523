// btfgmm sweep: every method fitted to one tile at each size of its ladder, measured against
// the tile; a table, sweep.json and an HTML report of the rate-distortion curves.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/measure/compare_data.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/report/report.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "parameter_options.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

struct SweepArguments {
  std::string btf, tile, out, methods;
  std::vector<std::size_t> components;  // sizes instead of the ladders
  // The fit's parameters every setting takes (precision, seed, threads, iterations, the
  // refinement's bounds), read as fit reads them, and the fields given.
  FitOptions options;
  std::vector<std::string_view> fields;
  bool keep_models = false, overwrite = false, quiet = false, json = false;
  bool methods_given = false;  // --methods was given (perhaps empty)
};

// --methods "gm,pca-btf": every name known (the nearest suggested), none twice; empty: all.
std::vector<std::string> method_names(const SweepArguments& o) {
  std::vector<std::string> names;
  if (o.methods.empty() && !o.methods_given) return names;
  std::string rest = o.methods;
  for (std::size_t at = 0; at <= rest.size();) {
    const std::size_t comma = std::min(rest.find(',', at), rest.size());
    const std::string name = rest.substr(at, comma - at);
    at = comma + 1;
    if (name.empty()) continue;
    try {
      find_method(name);
    } catch (const Error& e) {
      throw Error(e.kind(), fmt::format("--methods: {}", e.what()));
    }
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw Error(Error::Kind::kArgument,
                  fmt::format("--methods names '{}' twice; name each method once", name));
    names.push_back(name);
  }
  if (names.empty()) {
    std::string all;
    for (const MethodInfo& m : all_methods()) all += (all.empty() ? "" : ",") + std::string(m.name);
    throw Error(Error::Kind::kArgument,
                fmt::format("--methods '{}' names no method; give one or more of {} (or leave "
                            "--methods out for all of them)",
                            o.methods, all));
  }
  return names;
}

// The request the options make: methods, encoding, iterations, and --components as the
// sizes of every method in place of its ladder.
SweepRequest sweep_request(const SweepArguments& o) {
  SweepRequest r;
  r.methods = method_names(o);
  r.options = o.options;
  r.given = o.fields;
  if (!o.components.empty()) {
    std::vector<FitOptions> sizes;
    for (std::size_t c : o.components) {
      FitOptions s;
      s.components = c;
      sizes.push_back(s);
    }
    if (r.methods.empty())
      for (const MethodInfo& m : all_methods()) r.ladders[std::string(m.name)] = sizes;
    for (const std::string& name : r.methods) r.ladders[name] = sizes;
  }
  if (o.keep_models) r.model_folder = fs::path(o.out) / "models";
  return r;
}

// ---- progress on stderr --------------------------------------------------------------------

// "[3/12] gm components 30: ..." with the time since the sweep began and, once a setting is
// done, the sweep's share done and the time its rest should take; the method's own progress
// at most every 2 seconds.
class ProgressPrinter {
 public:
  void operator()(const SweepProgress& p) {
    using Event = SweepProgress::Event;
    const std::string head =
        fmt::format("[{}/{}] {} {}", p.index + 1, p.count, p.method, p.settings);
    const std::string at = std::isnan(p.remaining_seconds)
                               ? fmt::format("{} elapsed", human_seconds(p.elapsed_seconds))
                               : fmt::format("{} elapsed; sweep {:.0f}% done, about {} left",
                                             human_seconds(p.elapsed_seconds),
                                             100.0 * double(p.done) / double(p.count),
                                             human_seconds(p.remaining_seconds));
    switch (p.event) {
      case Event::kStart:
        fmt::print(stderr, "{}: fitting ({})\n", head, at);
        last_ = p.elapsed_seconds;
        break;
      case Event::kFit:
        if (p.elapsed_seconds - last_ < 2.0) break;
        fmt::print(stderr, "{}: {} {:.0f}% ({})\n", head, p.stage, 100.0 * p.fraction, at);
        last_ = p.elapsed_seconds;
        break;
      case Event::kMeasure:
        break;
      case Event::kDone: {
        const ModelComparison& c = *p.result;
        fmt::print(stderr, "{}: {}, 1:{:.1f} (file), PSNR {} dB, fit {}, decode {} ({})\n", head,
                   c.model->size_text(), c.model->file_ratio(c.file_bytes),
                   db_text(c.quality.psnr_db), human_seconds(c.fit_seconds),
                   human_seconds(c.decode_seconds), at);
        break;
      }
      case Event::kSkipped:
        fmt::print(stderr, "{}: skipped: {}\n", head, command_line_text(p.message));
        break;
    }
  }
  static std::string db_text(double v) {
    return std::isfinite(v) ? fmt::format("{:.2f}", v) : std::string("inf");
  }

 private:
  double last_ = 0.0;
};

// ---- the table and sweep.json --------------------------------------------------------------

// The synthesis models' texture statistics against the data (what `compare` prints for
// them): per image, each channel's mean and deviation, the autocorrelation at lags 1-4 and
// the luminance histogram, averaged over the images.
void print_texture_table(const SweepOutcome& s) {
  if (std::none_of(s.models.begin(), s.models.end(),
                   [](const ModelComparison& c) { return c.texture.has_value(); }))
    return;
  fmt::print(
      "synthesis models, texture statistics against the data (per image, averaged): |mean "
      "difference| and |deviation difference| (levels), deviation ratio model/data (lowest, "
      "highest), |autocorrelation difference| at lags 1-{}, histogram distance (0 to 1)\n",
      kTextureLags);
  fmt::print("{:<8} {:<14} {:>10} {:>10} {:>14} {:>10} {:>10}\n", "method", "size", "mean diff",
             "dev diff", "dev ratio", "autocorr", "histogram");
  for (const ModelComparison& c : s.models)
    if (c.texture) {
      const TextureStatistics& t = *c.texture;
      fmt::print("{:<8} {:<14} {:>10.2f} {:>10.2f} {:>14} {:>10.3f} {:>10.3f}\n", c.model->method(),
                 c.model->size_text(), t.mean_difference, t.deviation_difference,
                 fmt::format("{:.2f}-{:.2f}", t.lowest_deviation_ratio, t.highest_deviation_ratio),
                 t.autocorrelation_difference, t.histogram_distance);
    }
}

void print_table(const SweepOutcome& s) {
  fmt::print("{:<8} {:<14} {:>10} {:>10} {:>10} {:>10} {:>8} {:>8} {:>7} {:>8} {:>8}  {}\n",
             "method", "size", "values", "bytes", "C.R. paper", "C.R. file", "RMSE", "PSNR dB",
             "SSIM", "fit s", "decode s", "Pareto");
  for (std::size_t k = 0; k < s.models.size(); ++k) {
    const ModelComparison& c = s.models[k];
    fmt::print(
        "{:<8} {:<14} {:>10} {:>10} {:>10} {:>10} {:>8.4g} {:>8} {:>7.4f} {:>8.3f} {:>8.3f}  {}\n",
        c.model->method(), c.model->size_text(), c.model->parameter_count(), c.file_bytes,
        fmt::format("1:{:.1f}", c.model->paper_ratio()),
        fmt::format("1:{:.1f}", c.model->file_ratio(c.file_bytes)), c.quality.rmse,
        ProgressPrinter::db_text(c.quality.psnr_db), c.quality.ssim, c.fit_seconds,
        c.decode_seconds, c.texture ? "synthesis" : (s.pareto[k] ? "*" : ""));
  }
  print_texture_table(s);
  if (!s.models.empty()) {
    const BtfQuality& b = s.models[0].mean_brdf_only;
    fmt::print(
        "mean BRDF alone (each image its mean colour): RMSE {:.4g}, PSNR {} dB, SSIM {:.4f}\n",
        b.rmse, ProgressPrinter::db_text(b.psnr_db), b.ssim);
  }
  for (const SkippedSetting& k : s.skipped)
    fmt::print("skipped  {} {}: {}\n", k.method, k.settings, k.message);
  if (!s.not_iterated.empty())
    fmt::print("--iterations: {} take none (closed-form or fixed fits), fitted as usual\n",
               fmt::join(s.not_iterated, ", "));
  fmt::print(
      "* on the Pareto front: no model has a higher PSNR at the same or a higher "
      "compression ratio of its file (a synthesis is not on it: it makes new texture, which "
      "no pixel-wise PSNR measures)\n");
}

nlohmann::json model_json(const SweepOutcome& s, std::size_t k, bool kept) {
  const ModelComparison& c = s.models[k];
  nlohmann::json j;
  j["name"] = c.name;
  put_model_json(j, *c.model);
  j["settings"] = s.settings[k];
  j["file_bytes"] = c.file_bytes;
  if (kept) j["model_file"] = "models/" + c.name + ".btfgmm";
  j["compression_ratio_paper"] = c.model->paper_ratio();
  j["compression_ratio_file"] = c.model->file_ratio(c.file_bytes);
  j["rmse"] = c.quality.rmse;
  j["psnr_db"] = c.quality.psnr_db;  // +infinity (exact) is written as null
  j["ssim"] = c.quality.ssim;
  j["fit_seconds"] = c.fit_seconds;
  j["decode_seconds"] = c.decode_seconds;
  j["pareto"] = bool(s.pareto[k]);
  j["pixelwise_meaningful"] = !c.texture;
  if (c.texture) j["texture_statistics"] = texture_json(*c.texture);
  return j;
}

nlohmann::json sweep_json(const SweepArguments& o, const Btf& tile, const SweepOutcome& s) {
  nlohmann::json j;
  j["btf"] = o.btf;
  j["tile"] = {tile.origin().x, tile.origin().y, tile.width(), tile.height()};
  j["lights"] = tile.lights().size();
  j["views"] = tile.views().size();
  j["bit_depth"] = to_string(tile.format());
  j["precision"] = o.options.precision ? std::string(to_string(*o.options.precision))
                                       : std::string("fit's default");
  j["not_iterated"] = s.not_iterated;
  j["seed"] = o.options.seed;
  j["settings"] = s.total;
  j["stopped"] = s.stopped;
  j["models"] = nlohmann::json::array();
  for (std::size_t k = 0; k < s.models.size(); ++k)
    j["models"].push_back(model_json(s, k, o.keep_models));
  j["skipped"] = nlohmann::json::array();
  for (const SkippedSetting& k : s.skipped)
    j["skipped"].push_back(
        {{"method", k.method}, {"settings", k.settings}, {"message", k.message}});
  if (!s.models.empty()) {
    const BtfQuality& b = s.models[0].mean_brdf_only;
    j["mean_brdf_only"] = {{"rmse", b.rmse}, {"psnr_db", b.psnr_db}, {"ssim", b.ssim}};
  }
  return j;
}

// ---- the command ---------------------------------------------------------------------------

void run_sweep_command(const SweepArguments& o) {
  check_fit_options(o.options, o.fields, FitRoute::kSweep);  // before any work
  SweepRequest r = sweep_request(o);
  check_output_folder(o.out, o.overwrite);
  const auto t0 = Clock::now();
  BtfSource src = BtfSource::open(o.btf);
  const Btf tile = src.load(tile_option(src, o.tile, o.quiet));
  if (!o.quiet)
    fmt::print(stderr, "loaded {}x{} pixels at ({}, {}) x {} lights x {} views in {}\n",
               tile.width(), tile.height(), tile.origin().x, tile.origin().y, tile.lights().size(),
               tile.views().size(), human_seconds(seconds_since(t0)));
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec)
    throw Error(Error::Kind::kIo, fmt::format("cannot create the folder '{}': {}; check the path "
                                              "and its permissions",
                                              o.out, ec.message()));
  r.source = {o.btf, src.info().width, src.info().height};
  ProgressPrinter printer;
  if (!o.quiet) r.progress = [&](const SweepProgress& p) { printer(p); };
  r.stop = &g_stop;
  SweepOutcome s;
  {
    const StopOnSignals stop_on_signals;
    s = run_sweep(tile, r);
  }
  // The methods' messages name options as the command spells them, in the table, sweep.json
  // and the report.
  for (SkippedSetting& k : s.skipped) k.message = command_line_text(k.message);
  const nlohmann::json j = sweep_json(o, tile, s);
  const std::string text = json_text(j);
  write_file_atomically(fs::path(o.out) / "sweep.json",
                        std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()),
                        "sweep");
  if (o.json)
    std::cout << text;
  else
    print_table(s);
  if (s.models.empty() && s.stopped) {
    fmt::print(stderr, "sweep: interrupted before any model was fitted; {} holds only sweep.json\n",
               o.out);
    std::exit(130);
  }
  if (s.models.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("sweep: no setting could be fitted to this tile (the "
                            "first: {} {}: {}); give a larger tile or other sizes",
                            s.skipped[0].method, s.skipped[0].settings, s.skipped[0].message));
  ReportOptions ro;
  ro.command = "sweep";
  ro.data = &tile;
  ro.skipped = s.skipped;
  ro.note = fmt::format(
      "{} of {} settings fitted, factors stored as {}, seed {}{}", s.models.size(), s.total,
      o.options.precision ? std::string(to_string(*o.options.precision))
                          : std::string("as fit writes them by default (gm: compact)"),
      o.options.seed, s.stopped ? " (interrupted)" : "");
  write_report(o.out, o.btf, s.models, ro);
  if (!o.quiet)
    fmt::print(stderr, "wrote {} and {}{}\n", (fs::path(o.out) / "index.html").string(),
               (fs::path(o.out) / "sweep.json").string(),
               o.keep_models ? fmt::format(" and {} model files in {}", s.models.size(),
                                           r.model_folder.string())
                             : std::string());
  if (s.stopped) {
    fmt::print(stderr, "interrupted after {} of {} settings; the report holds those done\n",
               s.models.size() + s.skipped.size(), s.total);
    std::exit(130);
  }
}

// --methods' help: every method with its paper.
std::string methods_help() {
  std::string h = "Methods to sweep, comma-separated (default: all):";
  for (const MethodInfo& m : all_methods())
    h += fmt::format("\n  {:<8} {} ({})", m.name, m.title, m.citation);
  return h;
}

}  // namespace

void register_sweep_command(CLI::App& app, Commands& commands) {
  auto opt = std::make_shared<SweepArguments>();
  auto* c = app.add_subcommand(
      "sweep",
      "Fit every method to a tile at each size of its ladder (compression 1:5 to 1:500), "
      "measure each model, and write a table, sweep.json and an HTML report with the "
      "rate-distortion curves and their Pareto front");
  c->add_option("btf", opt->btf, "A BTF folder, Bonn .zip or Bonn .btf file")->required();
  c->add_option("--tile", opt->tile, fmt::format("X,Y,W,H of the tile, or {}", kAutoTileHelp))
      ->required();
  c->add_option("-o,--output", opt->out,
                "The folder to write (index.html, its pictures, sweep.json; new or empty)")
      ->required();
  auto* methods = c->add_option("--methods", opt->methods, methods_help());
  c->add_option("--components", opt->components,
                "Sizes fitted instead of each method's ladder, comma-separated: mixture "
                "components M (gm), eigen-images (pca-btf, pca-rf), components per cluster (lpca)")
      ->delimiter(',')
      ->check(CLI::Range(std::size_t(find_fit_parameter("components")->min),
                         std::size_t(find_fit_parameter("components")->max)));
  auto texts = std::make_shared<std::map<std::string, std::string>>();
  add_parameter_options(*c, FitRoute::kSweep, *texts);
  c->add_flag("--keep-models", opt->keep_models, "Also write every model to OUTDIR/models/");
  c->add_flag("--overwrite", opt->overwrite, "Replace the files of a non-empty output folder");
  c->add_flag("--json", opt->json, "Print sweep.json on stdout instead of the table");
  c->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
  commands.push_back({c, [opt, methods, texts, c] {
                        opt->methods_given = methods->count() > 0;
                        opt->fields = read_parameters(given_options(*c), *texts, opt->options,
                                                      FitRoute::kSweep);
                        run_sweep_command(*opt);
                      }});
}

}  // namespace btfgmm::cli
