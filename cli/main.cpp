// btfgmm: the command-line tool. A thin layer over the library: it parses options, calls the
// library, and formats what comes back. Errors from the library carry the file and the fix;
// they are printed as "btfgmm: error: ..." with exit status 1 (2 for bad usage).
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>

#include "btfgmm/btfgmm.hpp"

namespace fs = std::filesystem;
using btfgmm::Error;

namespace {

std::string human_bytes(double b) {
  const char* unit[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024.0 && u < 4) {
    b /= 1024.0;
    ++u;
  }
  return u == 0 ? fmt::format("{:.0f} B", b) : fmt::format("{:.1f} {}", b, unit[u]);
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
    case btfgmm::ImageFormat::kPng: return "PNG";
    case btfgmm::ImageFormat::kJpeg: return "JPEG";
    case btfgmm::ImageFormat::kExr: return "OpenEXR";
  }
  return "?";
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
  const fs::path out(o.out);
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw Error(Error::Kind::kArgument,
                fmt::format("output '{}' exists and is not a folder; give a new folder name",
                            o.out));
  if (fs::is_directory(out, ec) && !fs::is_empty(out, ec) && !o.overwrite)
    throw Error(Error::Kind::kArgument,
                fmt::format("output folder '{}' is not empty; give a new folder or add "
                            "--overwrite to replace its images",
                            o.out));
  const auto t0 = std::chrono::steady_clock::now();
  fmt::print(stderr, "generating {} ({}x{} pixels, {} lights x {} views, seed {})...\n",
             c.material, c.size, c.size, c.lights.size(), c.views.size(), c.seed);
  const btfgmm::Btf btf = btfgmm::generate(c);
  const auto t1 = std::chrono::steady_clock::now();
  btfgmm::write_utia(btf, out);
  const auto t2 = std::chrono::steady_clock::now();
  fmt::print(stderr, "wrote {} images to {} (rendered in {:.1f} s, written in {:.1f} s)\n",
             btf.image_count(), o.out, std::chrono::duration<double>(t1 - t0).count(),
             std::chrono::duration<double>(t2 - t1).count());
}

// ---- info --------------------------------------------------------------------------------

void run_info(const std::string& path, bool json) {
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
  fmt::print("  bit depth    {} ({})\n", btfgmm::to_string(i.format),
             format_name(i.image_format));
  fmt::print("  bytes        {} in files; {} as 8-bit RGB (W*H*ni*nv*3 = {:.0f})\n",
             human_bytes(double(i.file_bytes)), human_bytes(raw8), raw8);
  if (i.ignored_files > 0) fmt::print("  ignored      {} files that are not images\n",
                                      i.ignored_files);
  fmt::print("  first image  {}\n", src.image_name(0, 0));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "btfgmm: compress a BTF (an RGB image for every light and view direction) into a "
      "Gaussian mixture of product components, and evaluate it"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfgmm 0.1.0");

  GenerateOptions gen;
  auto* g = app.add_subcommand("generate", "Render a synthetic BTF of a procedural material "
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
  auto* inf = app.add_subcommand("info", "Describe a BTF (folder or Bonn .zip)");
  inf->add_option("path", info_path, "A BTF folder or .zip")->required();
  inf->add_flag("--json", info_json, "One JSON object for scripts");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (*g) run_generate(gen);
    if (*inf) run_info(info_path, info_json);
  } catch (const Error& e) {
    fmt::print(stderr, "btfgmm: error: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "btfgmm: internal error: {}\n", e.what());
    return 3;
  }
  return 0;
}
