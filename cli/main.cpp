// btfgmm: the command-line tool. A thin layer over the library: it parses options, calls the
// library, and formats what comes back. Errors from the library carry the file and the fix;
// they are printed as "btfgmm: error: ..." with exit status 1 (2 for bad usage).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model.hpp"
#include "cli_util.hpp"

namespace fs = std::filesystem;
using btfgmm::Error;
using namespace btfgmm::cli;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string describe_set(const btfgmm::DirectionSet& s) {
  if (s == btfgmm::DirectionSet::ubo81()) return "81 (the UBO2003/UTIA set)";
  double lo = 90, hi = 0;
  std::set<double> thetas;
  for (const auto& d : s) {
    lo = std::min(lo, d.theta_deg);
    hi = std::max(hi, d.theta_deg);
    thetas.insert(d.theta_deg);
  }
  return fmt::format("{} (theta {:g}..{:g} deg, {} distinct elevations)", s.size(), lo, hi,
                     thetas.size());
}

nlohmann::json set_json(const btfgmm::DirectionSet& s) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& d : s) a.push_back({d.theta_deg, d.phi_deg});
  return a;
}

std::string format_name(btfgmm::ImageFormat f) {
  switch (f) {
    case btfgmm::ImageFormat::kPng:
      return "PNG";
    case btfgmm::ImageFormat::kJpeg:
      return "JPEG";
    case btfgmm::ImageFormat::kExr:
      return "OpenEXR";
  }
  return "?";
}

// A path names a model file when it is a regular file that is not a zip.
bool is_model_path(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) return false;
  std::string ext = p.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext != ".zip";
}

// ---- generate ----------------------------------------------------------------------------

struct GenerateOptions {
  std::string material = "corduroy";
  int size = 32;
  std::uint64_t seed = 1;
  std::string lights = "ubo81", views = "ubo81";
  bool hdr = false;
  int supersample = 2;
  std::string out;
  bool overwrite = false;
};

void run_generate(const GenerateOptions& o) {
  btfgmm::GenerateConfig c;
  c.material = o.material;
  c.size = o.size;
  c.seed = o.seed;
  c.lights = btfgmm::DirectionSet::parse(o.lights);
  c.views = btfgmm::DirectionSet::parse(o.views);
  c.hdr = o.hdr;
  c.supersample = o.supersample;
  check_output_folder(o.out, o.overwrite);
  const auto t0 = Clock::now();
  fmt::print(stderr, "generating {} ({}x{} pixels, {} lights x {} views, seed {})...\n", c.material,
             c.size, c.size, c.lights.size(), c.views.size(), c.seed);
  const btfgmm::Btf btf = btfgmm::generate(c);
  const double rendered = since(t0);
  btfgmm::write_utia(btf, o.out);
  fmt::print(stderr, "wrote {} images to {} (rendered in {:.1f} s, written in {:.1f} s)\n",
             btf.image_count(), o.out, rendered, since(t0) - rendered);
}

// ---- info --------------------------------------------------------------------------------

void info_btf(const std::string& path, bool json) {
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(path);
  const btfgmm::BtfInfo& i = src.info();
  const std::uint64_t images = i.lights.size() * i.views.size();
  const double raw8 = double(images) * i.width * i.height * 3.0;
  if (json) {
    nlohmann::json j;
    j["path"] = path;
    j["kind"] = "btf";
    j["layout"] = btfgmm::to_string(i.layout);
    j["lights"] = i.lights.size();
    j["views"] = i.views.size();
    j["images"] = images;
    j["width"] = i.width;
    j["height"] = i.height;
    j["bit_depth"] = btfgmm::to_string(i.format);
    j["image_format"] = format_name(i.image_format);
    j["file_bytes"] = i.file_bytes;
    j["raw_bytes_8bit"] = std::uint64_t(raw8);
    j["ignored_files"] = i.ignored_files;
    j["light_directions"] = set_json(i.lights);
    j["view_directions"] = set_json(i.views);
    std::cout << j.dump(2) << "\n";
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  layout       {}\n", btfgmm::to_string(i.layout));
  fmt::print("  lights       {}\n", describe_set(i.lights));
  fmt::print("  views        {}\n", describe_set(i.views));
  fmt::print("  images       {} ({} x {})\n", images, i.lights.size(), i.views.size());
  fmt::print("  image size   {} x {} pixels, RGB\n", i.width, i.height);
  fmt::print("  bit depth    {} ({})\n", btfgmm::to_string(i.format), format_name(i.image_format));
  fmt::print("  bytes        {} in files; {} as 8-bit RGB (W*H*ni*nv*3 = {:.0f})\n",
             human_bytes(double(i.file_bytes)), human_bytes(raw8), raw8);
  if (i.ignored_files > 0)
    fmt::print("  ignored      {} files that are not images\n", i.ignored_files);
  fmt::print("  first image  {}\n", src.image_name(0, 0));
}

void info_model(const std::string& path, bool json) {
  const btfgmm::BtfModel m = btfgmm::load_model(path);
  const std::uint64_t bytes = fs::file_size(path);
  const auto& s = m.settings;
  if (json) {
    nlohmann::json j;
    j["path"] = path;
    j["kind"] = "model";
    j["format_version"] = btfgmm::kModelFormatVersion;
    j["tile"] = {m.origin.x, m.origin.y, m.width, m.height};
    j["lights"] = m.lights.size();
    j["views"] = m.views.size();
    j["bit_depth"] = btfgmm::to_string(m.format);
    j["components"] = m.mixture.size();
    j["components_requested"] = s.components;
    j["components_dropped"] = s.dropped;
    j["iterations"] = s.iterations;
    j["max_iterations"] = s.max_iterations;
    j["epsilon"] = s.epsilon;
    j["seed"] = s.seed;
    j["log_likelihood"] = s.log_likelihood;
    j["fit_seconds"] = s.seconds;
    j["precision"] = m.precision == btfgmm::Precision::kF16 ? "f16" : "f32";
    j["file_bytes"] = bytes;
    j["compression_ratio_paper"] = m.compression_ratio_paper();
    j["compression_ratio_file"] = m.compression_ratio_file(bytes);
    std::cout << j.dump(2) << "\n";
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  model        btfgmm format {}, {} parameters\n", btfgmm::kModelFormatVersion,
             m.precision == btfgmm::Precision::kF16 ? "16-bit float" : "32-bit float");
  fmt::print("  tile         {}x{} pixels at ({}, {}) of the source, {} data\n", m.width, m.height,
             m.origin.x, m.origin.y, btfgmm::to_string(m.format));
  fmt::print("  lights       {}\n", describe_set(m.lights));
  fmt::print("  views        {}\n", describe_set(m.views));
  fmt::print("  components   M = {} ({} requested, {} dropped by EM)\n", m.mixture.size(),
             s.components, s.dropped);
  fmt::print("  fit          {} of at most {} iterations, epsilon {:g}, seed {}, {}\n",
             s.iterations, s.max_iterations, s.epsilon, s.seed, human_seconds(s.seconds));
  fmt::print("  log-lik.     {:.6f} per sample (model units)\n", s.log_likelihood);
  fmt::print("  file         {} bytes ({})\n", bytes, human_bytes(double(bytes)));
  fmt::print("  compression  1:{:.1f} by the paper's count, 1:{:.1f} by the file's bytes\n",
             m.compression_ratio_paper(), m.compression_ratio_file(bytes));
}

// ---- fit ---------------------------------------------------------------------------------

struct FitOptions {
  std::string input, out, tile, precision = "f32";
  std::size_t components = 600;
  int iterations = 40;
  double epsilon = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false, quiet = false;
};

void run_fit(const FitOptions& o) {
  if (o.precision != "f32" && o.precision != "f16")
    throw Error(Error::Kind::kArgument,
                fmt::format("--precision '{}': give f32 or f16", o.precision));
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.input);
  const btfgmm::Tile tile = o.tile.empty() ? btfgmm::Tile{} : parse_tile(o.tile);
  const btfgmm::Btf btf = src.load(tile);
  const std::size_t n = btf.image_count() * std::size_t(btf.width()) * btf.height();
  if (!o.quiet)
    fmt::print(stderr,
               "loaded {}x{} pixels at ({}, {}) x {} lights x {} views = {} samples in {}\n",
               btf.width(), btf.height(), btf.origin().x, btf.origin().y, btf.lights().size(),
               btf.views().size(), n, human_seconds(since(t0)));
  btfgmm::FitConfig c;
  c.components = o.components;
  c.seed = o.seed;
  c.em.max_iterations = o.iterations;
  c.em.epsilon = o.epsilon;
  c.em.threads = o.threads;
  auto progress = [&](const btfgmm::EmProgress& p) {
    if (o.quiet) return;
    const double per = p.seconds / p.iteration;
    fmt::print(stderr,
               "iteration {:>3}/{}  L = {:.6f}  gain {:+.2e}  components {} ({} dropped)  {}  "
               "ETA {}\n",
               p.iteration, p.max_iterations, p.log_likelihood, p.relative_gain, p.components,
               p.dropped, human_seconds(p.seconds),
               human_seconds(per * (p.max_iterations - p.iteration)));
  };
  btfgmm::BtfModel model = btfgmm::fit_model(btf, c, progress);
  model.precision = o.precision == "f16" ? btfgmm::Precision::kF16 : btfgmm::Precision::kF32;
  btfgmm::save_model(model, o.out);
  const std::uint64_t bytes = fs::file_size(o.out);
  fmt::print(stderr,
             "wrote {}: M = {} ({} dropped), L = {:.6f}, {} bytes, compression 1:{:.1f} "
             "(paper's count) / 1:{:.1f} (file), fit in {}\n",
             o.out, model.mixture.size(), model.settings.dropped, model.settings.log_likelihood,
             bytes, model.compression_ratio_paper(), model.compression_ratio_file(bytes),
             human_seconds(model.settings.seconds));
}

// ---- decode ------------------------------------------------------------------------------

struct DecodeOptions {
  std::string model, out, size;
  std::vector<std::string> lights, views;
  bool overwrite = false;
};

void run_decode(const DecodeOptions& o) {
  const btfgmm::BtfModel m = btfgmm::load_model(o.model);
  check_output_folder(o.out, o.overwrite);
  auto directions = [](const std::vector<std::string>& given, const btfgmm::DirectionSet& all,
                       const char* option) {
    if (given.empty()) return all;
    std::vector<btfgmm::Direction> d;
    for (const auto& g : given) d.push_back(parse_direction(g, option));
    return btfgmm::DirectionSet(std::move(d));
  };
  const btfgmm::DirectionSet lights = directions(o.lights, m.lights, "--light");
  const btfgmm::DirectionSet views = directions(o.views, m.views, "--view");
  const auto [w, h] = o.size.empty() ? std::pair{m.width, m.height} : parse_size(o.size);
  const auto t0 = Clock::now();
  // One light at a time: a large repeated size need not fit in memory at once.
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const btfgmm::Btf part = btfgmm::decode(m, btfgmm::DirectionSet({lights[l]}), views, w, h);
    btfgmm::write_utia(part, o.out);
  }
  fmt::print(stderr, "wrote {} images of {}x{} pixels to {} in {}\n", lights.size() * views.size(),
             w, h, o.out, human_seconds(since(t0)));
}

// ---- eval --------------------------------------------------------------------------------

struct EvalOptions {
  std::string model, light, view;
  double x = 0, y = 0;
  bool json = false;
};

void run_eval(const EvalOptions& o) {
  const btfgmm::BtfModel m = btfgmm::load_model(o.model);
  const btfgmm::Query q{o.x, o.y, parse_direction(o.light, "--light"),
                        parse_direction(o.view, "--view")};
  const auto rgb = btfgmm::predict(m, q);
  if (o.json) {
    nlohmann::json j;
    j["x"] = o.x;
    j["y"] = o.y;
    j["light"] = {q.light.theta_deg, q.light.phi_deg};
    j["view"] = {q.view.theta_deg, q.view.phi_deg};
    j["rgb"] = {rgb[0], rgb[1], rgb[2]};
    std::cout << j.dump() << "\n";
  } else {
    fmt::print("{:.4f} {:.4f} {:.4f}\n", rgb[0], rgb[1], rgb[2]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "btfgmm: compress a BTF (an RGB image for every light and view direction) into a "
      "Gaussian mixture of product components, and evaluate it"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfgmm 0.1.0");

  GenerateOptions gen;
  auto* g = app.add_subcommand("generate",
                               "Render a synthetic BTF of a procedural material "
                               "and write it in the UTIA layout");
  g->add_option("--material", gen.material, "Material: corduroy, knit, bumps, ...")
      ->capture_default_str();
  g->add_option("--size", gen.size, "Image width = height in pixels")
      ->check(CLI::Range(4, 8192))
      ->capture_default_str();
  g->add_option("--seed", gen.seed, "Random seed (equal seeds give equal BTFs)")
      ->capture_default_str();
  g->add_option("--lights", gen.lights, "Light directions: ubo81, spiral:N, rings:T/N,...")
      ->capture_default_str();
  g->add_option("--views", gen.views, "View directions: ubo81, spiral:N, rings:T/N,...")
      ->capture_default_str();
  g->add_flag("--hdr", gen.hdr, "Write linear float OpenEXR images instead of 8-bit PNG");
  g->add_option("--supersample", gen.supersample, "Rays per pixel side")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  g->add_option("-o,--output", gen.out, "Output folder")->required();
  g->add_flag("--overwrite", gen.overwrite, "Replace images in a non-empty output folder");

  std::string info_path;
  bool info_json = false;
  auto* inf = app.add_subcommand("info", "Describe a BTF (folder or Bonn .zip) or a model file");
  inf->add_option("path", info_path, "A BTF folder or .zip, or a .btfgmm model")->required();
  inf->add_flag("--json", info_json, "One JSON object for scripts");

  FitOptions fit;
  auto* f = app.add_subcommand("fit", "Fit the Gaussian mixture model to a BTF tile");
  f->add_option("input", fit.input, "A BTF folder or Bonn .zip")->required();
  f->add_option("--tile", fit.tile, "X,Y,W,H of the tile to fit (default: the whole image)");
  f->add_option("--components,-M", fit.components, "Number of mixture components M")
      ->check(CLI::Range(std::size_t(1), std::size_t(100000)))
      ->capture_default_str();
  f->add_option("--iterations", fit.iterations, "Maximum EM iterations")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  f->add_option("--epsilon", fit.epsilon, "Stop when the relative gain of L is below this")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  f->add_option("--seed", fit.seed, "Seed of the random initialisation")->capture_default_str();
  f->add_option("--threads", fit.threads,
                "Threads (0: all cores; the model does not depend "
                "on it)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  f->add_option("--precision", fit.precision, "Parameters stored as f32 or f16")
      ->capture_default_str();
  f->add_option("-o,--output", fit.out, "The model file to write (.btfgmm)")->required();
  f->add_flag("--overwrite", fit.overwrite, "Replace an existing model file");
  f->add_flag("-q,--quiet", fit.quiet, "No progress on stderr");

  DecodeOptions dec;
  auto* d = app.add_subcommand("decode", "Decode a model into images (UTIA layout)");
  d->add_option("model", dec.model, "A .btfgmm model")->required();
  d->add_option("-o,--output", dec.out, "Output folder")->required();
  d->add_option("--light", dec.lights,
                "Light THETA,PHI in degrees (repeatable; default: the "
                "measured set)");
  d->add_option("--view", dec.views,
                "View THETA,PHI in degrees (repeatable; default: the "
                "measured set)");
  d->add_option("--size", dec.size, "N or WxH pixels, the tile repeated (default: the tile)");
  d->add_flag("--overwrite", dec.overwrite, "Replace images in a non-empty output folder");

  EvalOptions ev;
  auto* e = app.add_subcommand("eval", "Evaluate a model at one pixel, light and view");
  e->add_option("model", ev.model, "A .btfgmm model")->required();
  e->add_option("--x", ev.x, "Pixel x (any real number; the tile repeats)")->required();
  e->add_option("--y", ev.y, "Pixel y (any real number; the tile repeats)")->required();
  e->add_option("--light", ev.light, "Light THETA,PHI in degrees")->required();
  e->add_option("--view", ev.view, "View THETA,PHI in degrees")->required();
  e->add_flag("--json", ev.json, "One JSON object for scripts");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& err) {
    return app.exit(err);
  }

  try {
    if (*g) run_generate(gen);
    if (*inf)
      is_model_path(info_path) ? info_model(info_path, info_json) : info_btf(info_path, info_json);
    if (*f) run_fit(fit);
    if (*d) run_decode(dec);
    if (*e) run_eval(ev);
  } catch (const Error& err) {
    fmt::print(stderr, "btfgmm: error: {}\n", err.what());
    return 1;
  } catch (const std::exception& err) {
    fmt::print(stderr, "btfgmm: internal error: {}\n", err.what());
    return 3;
  }
  return 0;
}
