// btfgmm rangemap: the relief of a BTF tile, as the probabilistic texture models store it.
#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <string>

#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/methods/range_map.hpp"
#include "commands.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

struct RangeMapArguments {
  std::string input, out, tile;
  double max_light_theta = 60.0;
};

void run_rangemap(const RangeMapArguments& o) {
  output_image_format(o.out);  // a bad name fails before any work
  BtfSource src = BtfSource::open(o.input);
  const Btf btf = src.load(tile_option(src, o.tile, false));
  RangeMapSettings s;
  s.max_light_theta_deg = o.max_light_theta;
  const RangeMap map = estimate_range_map(btf, s);
  const auto normals = write_range_map(o.out, map);
  const auto [lo, hi] = std::minmax_element(map.heights.begin(), map.heights.end());
  fmt::print("range map {} x {} from view {} (heights {:.3f} to {:.3f} pixels): {}\n", map.width,
             map.height, top_view(btf), *lo, *hi, o.out);
  fmt::print("normal map: {}\n", normals.string());
}

}  // namespace

void register_rangemap_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RangeMapArguments>();
  auto* r = app.add_subcommand(
      "rangemap",
      "The range map of a BTF: photometric-stereo normals from the top view's images, "
      "integrated by Frankot-Chellappa (periodic: it tiles); also writes STEM-normals.png");
  r->add_option("input", o->input, "BTF folder or Bonn .zip")->required();
  r->add_option("-o,--out", o->out, "range map: .exr (heights in pixels) or .png (scaled)")
      ->required();
  r->add_option("--tile", o->tile,
                fmt::format("X,Y,W,H, or {} (default: the whole image)", kAutoTileHelp));
  r->add_option("--max-light-theta", o->max_light_theta,
                "leave out lights above this elevation, degrees")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 90.0));
  r->footer("Example: btfgmm rangemap corduroy32/ -o corduroy-range.exr");
  commands.push_back({r, [o] { run_rangemap(*o); }});
}

}  // namespace btfgmm::cli
