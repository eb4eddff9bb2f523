// btfgmm generate: a synthetic BTF of a procedural material.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "provenance_text.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

// ---- generate ----------------------------------------------------------------------------

struct GenerateArguments {
  std::string material = "corduroy";
  int size = 32;
  std::uint64_t seed = 1;
  std::string lights = "ubo81", views = "ubo81";
  bool hdr = false;
  int supersample = 2;
  std::string out;
  bool overwrite = false, quiet = false;
};

// A line at every tenth of a stage's work once a second has passed since the start (short
// runs stay quiet), with the time the stage has left.
class GenerateProgress {
 public:
  void operator()(std::string_view stage, double fraction) {
    if (stage != stage_) {
      stage_ = stage;
      stage_start_ = Clock::now();
      printed_ = 0;
    }
    const int tenth = int(fraction * 10.0 + 1e-9);
    if (tenth <= printed_ || fraction >= 1.0 || seconds_since(start_) < 1.0) return;
    printed_ = tenth;
    const double seconds = seconds_since(stage_start_);
    fmt::print(stderr, "{}: {:>3.0f}% of the images, {} so far, about {} left\n", stage,
               100.0 * fraction, human_seconds(seconds),
               human_seconds(seconds * (1.0 - fraction) / fraction));
  }

 private:
  std::string stage_;
  Clock::time_point start_ = Clock::now(), stage_start_ = start_;
  int printed_ = 0;
};

void run_generate(const GenerateArguments& o) {
  btfgmm::GenerateConfig c;
  c.material = o.material;
  c.size = o.size;
  c.seed = o.seed;
  c.lights = btfgmm::DirectionSet::parse(o.lights);
  c.views = btfgmm::DirectionSet::parse(o.views);
  c.hdr = o.hdr;
  c.supersample = o.supersample;
  btfgmm::check_generate_config(c);  // before anything is announced or written
  check_output_folder(o.out, o.overwrite);
  const auto t0 = Clock::now();
  if (!o.quiet) {
    const double images = double(c.lights.size() * c.views.size());
    fmt::print(stderr,
               "generating {} ({}x{} pixels, {} lights x {} views: {:.0f} images, {} of "
               "pixels held in memory, seed {})...\n",
               c.material, c.size, c.size, c.lights.size(), c.views.size(), images,
               btfgmm::human_bytes(images * c.size * c.size * 3 * sizeof(float)), c.seed);
  }
  GenerateProgress progress;
  if (!o.quiet)
    c.progress = [&](double fraction, std::string_view) { progress("rendering", fraction); };
  const btfgmm::Btf btf = btfgmm::generate(c);
  const double rendered = seconds_since(t0);
  std::function<void(double)> written;
  if (!o.quiet) written = [&](double fraction) { progress("writing", fraction); };
  btfgmm::write_utia(btf, o.out, std::nullopt, written);
  if (!o.quiet)
    fmt::print(stderr, "wrote {} images to {} (rendered in {:.1f} s, written in {:.1f} s)\n",
               btf.image_count(), o.out, rendered, seconds_since(t0) - rendered);
}

// --material's help: every material, from the library's one list.
std::string material_help() {
  std::string h = "The material:";
  for (const btfgmm::MaterialInfo& m : btfgmm::materials())
    h += fmt::format("\n  {:<9} {}", m.name, m.description);
  return h;
}

}  // namespace

void register_generate_command(CLI::App& app, Commands& commands) {
  auto gen = std::make_shared<GenerateArguments>();
  auto* g = app.add_subcommand("generate",
                               "Render a synthetic BTF of a procedural material "
                               "and write it in the UTIA layout");
  g->add_option("--material", gen->material, material_help())->capture_default_str();
  g->add_option("--size", gen->size, "Image width = height in pixels")
      ->check(CLI::Range(4, 8192))
      ->capture_default_str();
  g->add_option("--seed", gen->seed, "Random seed (equal seeds give equal BTFs)")
      ->capture_default_str();
  g->add_option("--lights", gen->lights, "Light directions: ubo81, spiral:N, rings:T/N,...")
      ->capture_default_str();
  g->add_option("--views", gen->views, "View directions: ubo81, spiral:N, rings:T/N,...")
      ->capture_default_str();
  g->add_flag("--hdr", gen->hdr, "Write linear float OpenEXR images instead of 8-bit PNG");
  g->add_option("--supersample", gen->supersample, "Rays per pixel side")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  g->add_option("-o,--output", gen->out, "Output folder")->required();
  g->add_flag("--overwrite", gen->overwrite, "Replace images in a non-empty output folder");
  g->add_flag("-q,--quiet", gen->quiet, "No progress on stderr");

  commands.push_back({g, [gen] { run_generate(*gen); }});
}

}  // namespace btfgmm::cli
