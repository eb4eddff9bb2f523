// btfgmm convert: any data set btfgmm reads, a tile or whole, to the UTIA layout as PNG or EXR
// (the writing is the library's convert_to_utia).
#include <fmt/format.h>

#include <memory>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

struct ConvertCommandOptions {
  std::string data, out, tile, format;
  double exposure = 1.0;
  bool overwrite = false, quiet = false;
};

void run_convert(const ConvertCommandOptions& o) {
  btfgmm::BtfSource src = btfgmm::BtfSource::open(o.data);
  btfgmm::ConvertOptions c;
  if (o.format == "png") c.format = btfgmm::ImageFormat::kPng;
  if (o.format == "exr") c.format = btfgmm::ImageFormat::kExr;
  c.exposure = o.exposure;
  const btfgmm::Tile tile = tile_option(src, o.tile, o.quiet);
  check_output_folder(o.out, o.overwrite);
  const btfgmm::ConvertPlan plan = btfgmm::plan_conversion(src, tile, o.out, c);
  if (!o.quiet)
    fmt::print(stderr, "convert: {} {} images of {}x{} pixels to {}, {} of pixels before {}\n",
               plan.images, btfgmm::to_string(plan.format), plan.tile.width, plan.tile.height,
               o.out, btfgmm::human_bytes(double(plan.pixel_bytes)),
               plan.format == btfgmm::ImageFormat::kExr ? "the EXR headers" : "compression");
  StopOnSignals signals;
  c.stopped = [] { return g_stop.load(); };
  const auto t0 = Clock::now();
  int printed = 0;
  if (!o.quiet)
    c.progress = [&](double fraction) {
      const int tenth = int(fraction * 10.0 + 1e-9);
      if (tenth <= printed || fraction >= 1.0 || seconds_since(t0) < 1.0) return;
      printed = tenth;
      const double elapsed = seconds_since(t0);
      fmt::print(stderr, "convert: {:>3.0f}% of the images, {} so far, about {} left\n",
                 100.0 * fraction, human_seconds(elapsed),
                 human_seconds(elapsed * (1.0 - fraction) / fraction));
    };
  const btfgmm::ConvertResult r = btfgmm::convert_to_utia(src, tile, o.out, c);
  if (!o.quiet)
    fmt::print(stderr, "wrote {} {} images of {}x{} pixels to {} in {}\n{}", r.images,
               btfgmm::to_string(r.format), r.tile.width, r.tile.height, o.out,
               human_seconds(seconds_since(t0)), r.note);
}

}  // namespace

void register_convert_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<ConvertCommandOptions>();
  auto* c = app.add_subcommand(
      "convert",
      "Write a data set (image folder, Bonn .zip or Bonn .btf file), a tile or whole, in the UTIA "
      "layout as PNG or EXR. Memory: one image's tile per thread; for a .btf file also the "
      "tile's factors (components x tile pixels x 4 bytes per channel), never the whole images");
  c->add_option("data", o->data, "A BTF folder, Bonn .zip or Bonn .btf file")->required();
  c->add_option(
      "--tile", o->tile,
      fmt::format("X,Y,W,H: the pixels to write (default: the whole image), or {}", kAutoTileHelp));
  c->add_option("--format", o->format,
                "png (8-bit) or exr (linear float); default: exr for HDR data, png for 8-bit")
      ->check(CLI::IsMember({"png", "exr"}));
  c->add_option("--exposure", o->exposure,
                "PNG only: HDR values are written as 8-bit linear levels 255 x EXPOSURE x value "
                "(clamped); 8-bit levels are multiplied by it. conversion.txt states it")
      ->capture_default_str();
  c->add_option("-o,--output", o->out, "Output folder")->required();
  c->add_flag("--overwrite", o->overwrite, "Replace images in a non-empty output folder");
  c->add_flag("-q,--quiet", o->quiet, "No progress on stderr");
  commands.push_back({c, [o] { run_convert(*o); }});
}

}  // namespace btfgmm::cli
