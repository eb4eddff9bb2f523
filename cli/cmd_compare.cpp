// btfgmm compare: models against the BTF they were fitted to, as the paper measures them
// (RMSE, PSNR, SSIM, compression ratios), as a table, JSON, or an HTML report.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <span>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/measure/compare_data.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/report/report.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "device_option.hpp"
#include "provenance_text.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

struct CompareArguments {
  std::string btf, report;
  std::vector<std::string> models;
  std::size_t worst = 3;
  std::string device = "auto";
  bool json = false, overwrite = false, quiet = false, force = false;
};

std::string pair_text(const ModelFrame& m, std::size_t image) {
  const std::size_t nv = m.views.size();
  const Direction& l = m.lights[image / nv];
  const Direction& v = m.views[image % nv];
  return fmt::format("light ({:g}, {:g}) view ({:g}, {:g})", l.theta_deg, l.phi_deg, v.theta_deg,
                     v.phi_deg);
}

// A synthesis model's statistics (pixel-wise figures mean nothing for new texture), in place
// of RMSE, PSNR and SSIM.
void print_texture_statistics(const TextureStatistics& t) {
  fmt::print(
      "  synthesis    makes new texture with the data's statistics (pixel-wise RMSE, PSNR "
      "and SSIM mean nothing for it; the JSON still holds them)\n");
  fmt::print(
      "  mean         data {:.2f} {:.2f} {:.2f}, model {:.2f} {:.2f} {:.2f} (R G B; per "
      "image |difference| {:.2f} on average, {:.2f} at most)\n",
      t.data_mean[0], t.data_mean[1], t.data_mean[2], t.model_mean[0], t.model_mean[1],
      t.model_mean[2], t.mean_difference, t.worst_mean_difference);
  fmt::print(
      "  deviation    data {:.2f} {:.2f} {:.2f}, model {:.2f} {:.2f} {:.2f} (per image "
      "ratio model/data {:.2f} to {:.2f})\n",
      t.data_deviation[0], t.data_deviation[1], t.data_deviation[2], t.model_deviation[0],
      t.model_deviation[1], t.model_deviation[2], t.lowest_deviation_ratio,
      t.highest_deviation_ratio);
  fmt::print(
      "  histogram    luminance, 32 bins: total-variation distance {:.3f} (0: equal, 1: "
      "disjoint)\n",
      t.histogram_distance);
  fmt::print(
      "  correlation  normalised autocorrelation at lags 1-{} in x and y: |difference| {:.3f} "
      "on average, {:.3f} at most\n",
      t.max_lag, t.autocorrelation_difference, t.worst_autocorrelation_difference);
  fmt::print(
      "  streak       largest row/column mean jump, model/data: {:.2f} at most; saturated "
      "values (0 or 255) data {:.2f} %, model {:.2f} %\n",
      t.worst_streak_ratio, 100 * t.saturated_data, 100 * t.saturated_model);
}

std::string db(double v) {
  return std::isfinite(v) ? fmt::format("{:.2f}", v) : "inf";
}

// The file's size and the decode's time.
void print_size_lines(const ModelComparison& c) {
  fmt::print("  compression  1:{:.1f} by the paper's count, 1:{:.1f} by the file's {} bytes ({})\n",
             c.model->paper_ratio(), c.model->file_ratio(c.file_bytes), c.file_bytes,
             human_bytes(double(c.file_bytes)));
  fmt::print("  decoded      every image of the tile in {}\n", human_seconds(c.decode_seconds));
}

void print_comparison(const ModelComparison& c) {
  const ModelFrame& m = c.model->frame();
  const BtfQuality& q = c.quality;
  fmt::print("{}\n", c.name);
  fmt::print("  tile         {}x{} pixels at ({}, {}), {} lights x {} views, {} data\n",
             c.tile.width, c.tile.height, c.tile.x, c.tile.y, m.lights.size(), m.views.size(),
             to_string(m.format));
  print_model_lines(*c.model);
  if (c.texture) {
    print_texture_statistics(*c.texture);
    print_size_lines(c);
    return;
  }
  fmt::print("               {:>8} {:>8} {:>8} {:>8}   {:<44} {}\n", "overall", "red", "green",
             "blue", "worst image", "best image");
  const bool hdr = m.format == SampleFormat::kHdr;  // any scale: significant digits
  auto rm = [&](double v) { return hdr ? fmt::format("{:.4g}", v) : fmt::format("{:.3f}", v); };
  fmt::print("  RMSE         {:>8} {:>8} {:>8} {:>8}   {:<44} {}\n", rm(q.rmse), rm(q.rmse_rgb[0]),
             rm(q.rmse_rgb[1]), rm(q.rmse_rgb[2]),
             fmt::format("{:>7}  {}", rm(q.images[q.worst_psnr].rmse), pair_text(m, q.worst_psnr)),
             fmt::format("{:>7}  {}", rm(q.images[q.best_psnr].rmse), pair_text(m, q.best_psnr)));
  fmt::print(
      "  PSNR (dB)    {:>8} {:>8} {:>8} {:>8}   {:<44} {}\n", db(q.psnr_db), db(q.psnr_db_rgb[0]),
      db(q.psnr_db_rgb[1]), db(q.psnr_db_rgb[2]),
      fmt::format("{:>7}  {}", db(q.images[q.worst_psnr].psnr_db), pair_text(m, q.worst_psnr)),
      fmt::format("{:>7}  {}", db(q.images[q.best_psnr].psnr_db), pair_text(m, q.best_psnr)));
  fmt::print("  SSIM         {:>8.4f} {:>8.4f} {:>8.4f} {:>8.4f}   {:<44} {}\n", q.ssim,
             q.ssim_rgb[0], q.ssim_rgb[1], q.ssim_rgb[2],
             fmt::format("{:>7.4f}  {}", q.images[q.worst_ssim].ssim, pair_text(m, q.worst_ssim)),
             fmt::format("{:>7.4f}  {}", q.images[q.best_ssim].ssim, pair_text(m, q.best_ssim)));
  fmt::print(
      "  mean BRDF    alone (each image its mean colour): RMSE {}, PSNR {} dB, SSIM {:.4f}\n",
      rm(c.mean_brdf_only.rmse), db(c.mean_brdf_only.psnr_db), c.mean_brdf_only.ssim);
  print_size_lines(c);
  fmt::print(
      "  measured     {}; PSNR = 20 log10(R / RMSE); SSIM {}x{} Gaussian window, sigma "
      "1.5, K1 0.01, K2 0.03, no padding{}\n",
      m.format == SampleFormat::kHdr
          ? fmt::format("RMSE in the data's units, R = {:g} (the original's peak)", q.range)
          : std::string("RMSE in levels of 0-255, R = 255"),
      q.ssim_window, q.ssim_window, q.ssim_window < 11 ? " (shrunk to the tile)" : "");
}

// A BTF is a folder or a .zip.
bool is_btf_path(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec) || (fs::is_regular_file(path, ec) && !is_model_path(path));
}

// The BTF comes first, then the models: a model first, with the BTF after it, is the order
// reversed, and the message shows the command in the right order.
void check_argument_order(const CompareArguments& o) {
  if (!is_model_path(o.btf)) return;
  std::vector<std::string> btfs, models{o.btf};
  for (const std::string& m : o.models) (is_btf_path(m) ? btfs : models).push_back(m);
  if (btfs.size() == 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("the arguments are in the wrong order: '{}' is a model and '{}' the "
                            "BTF; give the BTF first, then the models: btfgmm compare {} {}",
                            o.btf, btfs[0], btfs[0], fmt::join(models, " ")));
}

// A model's tile of the data against the data it records (check_fitted_data).
DataMatch check_data(const Representation& model, const std::string& name, const Btf& tile,
                     const BtfInfo& info, const CompareArguments& o) {
  return enforce_data_check(check_fitted_data(model, name, tile, {o.btf, info.width, info.height}),
                            o.force, o.quiet, "compare");
}

// The models side by side, those on the Pareto front of PSNR against the file's compression
// ratio marked.
void print_models_table(const std::vector<ModelComparison>& results) {
  const std::vector<bool> front = pareto_front(results);
  fmt::print("\n{:<36} {:<8} {:<14} {:>9} {:>8} {:>7} {:>10} {:>10} {:>10} {:>8}  {}\n", "model",
             "method", "size", "RMSE", "PSNR dB", "SSIM", "C.R. paper", "C.R. file", "file",
             "decode s", "Pareto");
  for (std::size_t k = 0; k < results.size(); ++k) {
    const ModelComparison& c = results[k];
    fmt::print("{:<36} {:<8} {:<14} {:>9.4g} {:>8} {:>7.4f} {:>10} {:>10} {:>10} {:>8.3f}  {}\n",
               c.name, c.model->method(), c.model->size_text(), c.quality.rmse,
               db(c.quality.psnr_db), c.quality.ssim,
               fmt::format("1:{:.1f}", c.model->paper_ratio()),
               fmt::format("1:{:.1f}", c.model->file_ratio(c.file_bytes)),
               human_bytes(double(c.file_bytes)), c.decode_seconds, front[k] ? "*" : "");
  }
}

// Every model read and checked against the BTF's frame.
std::vector<std::shared_ptr<const Representation>> read_models(const CompareArguments& o,
                                                               const BtfInfo& info) {
  std::vector<std::shared_ptr<const Representation>> models;
  for (const std::string& path : o.models) {
    std::error_code ec;
    if (!fs::exists(path, ec))
      throw Error(Error::Kind::kIo,
                  fmt::format("model '{}' does not exist; give the path of a .btfgmm file written "
                              "by btfgmm fit",
                              path));
    const std::shared_ptr<Representation> model = load_representation(path);
    check_model_frame(*model, path, info, o.btf);
    const std::string where = compute_on_device(*model, o.device, path);
    if (!o.quiet && where != "the CPU") fmt::print(stderr, "predicting {} on {}\n", path, where);
    models.push_back(model);
  }
  return models;
}

void run_compare(const CompareArguments& o) {
  check_argument_order(o);
  if (!o.report.empty()) check_output_folder(o.report, o.overwrite);
  const BtfSource src = BtfSource::open(o.btf);
  const BtfInfo& info = src.info();
  std::optional<Btf> tile_data, first_tile;
  std::vector<ModelComparison> results;
  btfgmm::CompareOptions co;
  co.worst_pairs = o.worst;
  // Every model is read and checked against the BTF before any work.
  const std::vector<std::shared_ptr<const Representation>> models = read_models(o, info);
  // Then each model's tile of the data is the data it was fitted to, by its provenance: a crop,
  // or the seamless tile it names made again.
  std::vector<BtfSource> fitted;
  for (const auto& model : models) fitted.push_back(fitted_source(src, model->provenance()));
  const auto load_tile = [&](std::size_t k) {
    const ModelFrame& m = models[k]->frame();
    const Tile tile{.x = m.origin.x, .y = m.origin.y, .width = m.width, .height = m.height};
    const auto* map = fitted[k].pixel_map();
    if (!tile_data || tile_data->origin() != tile ||
        tile_data->made_from() != (map ? map->description : std::string()))
      tile_data = fitted[k].load(tile);
    return tile;
  };
  std::vector<DataMatch> matches;
  for (std::size_t k = 0; k < models.size(); ++k) {
    load_tile(k);
    matches.push_back(check_data(*models[k], o.models[k], *tile_data, info, o));
  }
  for (std::size_t k = 0; k < models.size(); ++k) {
    const auto t0 = Clock::now();
    const std::string& path = o.models[k];
    const Tile tile = load_tile(k);
    results.push_back(
        compare_model(*tile_data, models[k], path, std::uint64_t(fs::file_size(path)), co));
    if (k == 0 && !o.report.empty()) first_tile = *tile_data;  // the report's side by side
    if (!o.quiet)
      fmt::print(stderr, "compared {} with its {}x{} tile of {} in {}\n", path, tile.width,
                 tile.height, o.btf, human_seconds(seconds_since(t0)));
  }

  nlohmann::json all = nlohmann::json::array();
  for (std::size_t k = 0; k < results.size(); ++k) {
    all.push_back(comparison_json(o.btf, results[k], matches[k]));
  }
  if (o.json) {
    std::cout << json_text(results.size() == 1 ? all[0] : all);
  } else {
    fmt::print("{}: {} lights x {} views, {}x{} pixels, {} data\n\n", o.btf, info.lights.size(),
               info.views.size(), info.width, info.height, to_string(info.format));
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (i) fmt::print("\n");
      print_comparison(results[i]);
    }
    if (results.size() > 1) print_models_table(results);
  }
  if (!o.report.empty()) {
    ReportOptions ro;
    ro.data = first_tile ? &*first_tile : nullptr;
    write_report(o.report, o.btf, results, ro);
    const std::string json = json_text(all);
    btfgmm::write_file_atomically(
        fs::path(o.report) / "compare.json",
        std::span(reinterpret_cast<const std::uint8_t*>(json.data()), json.size()), "report");
    if (!o.quiet)
      fmt::print(stderr, "wrote the report {}\n", (fs::path(o.report) / "index.html").string());
  }
}

}  // namespace

void register_compare_command(CLI::App& app, Commands& commands) {
  auto opt = std::make_shared<CompareArguments>();
  auto* c = app.add_subcommand(
      "compare",
      "Measure models against the BTF they were fitted to: RMSE, PSNR, SSIM, compression "
      "ratios; a table, JSON, or an HTML report");
  c->add_option("btf", opt->btf, "The BTF folder or Bonn .zip the models were fitted to")
      ->required();
  c->add_option("models", opt->models, "One or more .btfgmm models of that BTF")->required();
  c->add_flag("--json", opt->json,
              "JSON for scripts: one object (an array of objects for several models)");
  c->add_option("--report", opt->report,
                "Write an HTML report (index.html, pictures, curves) to this folder");
  c->add_option("--worst", opt->worst, "Pictures of the N worst (light, view) images in the report")
      ->check(CLI::Range(std::size_t(0), std::size_t(100)))
      ->capture_default_str();
  c->add_flag("--overwrite", opt->overwrite, "Replace the files of a non-empty report folder");
  c->add_flag("--force", opt->force,
              "Compare even where a model's provenance records other data than the BTF's tile");
  add_device_option(c, opt->device);
  c->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");

  commands.push_back({c, [opt] { run_compare(*opt); }});
}

}  // namespace btfgmm::cli
