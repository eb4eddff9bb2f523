// btfgmm tile -o: a seamless tile cut from the data (btfgmm/measure/seamless_tile.hpp),
// written as a UTIA folder with its pixel map, and the report of how its wrap and cut compare
// with the material's own steps and with the best crop's wrap.
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/seamless_tile.hpp"
#include "btfgmm/measure/tile.hpp"
#include "cli_util.hpp"
#include "stop_signals.hpp"
#include "tile_command.hpp"

namespace btfgmm::cli {
namespace {

// What a wrap ratio means for the tile repeated on a surface, in words.
const char* wrap_verdict(double ratio) {
  if (ratio <= 1.2) return "the wrap looks like any step inside the material";
  if (ratio <= 1.5) return "the wrap is a little sharper than the material's own steps";
  return "the wrap shows as a line where the tile repeats";
}

// Prints "NAME: NN% of the images, ..." every tenth after the first second.
std::function<void(double)> progress_lines(const char* name, bool quiet) {
  if (quiet) return {};
  return [name, t0 = Clock::now(), printed = 0](double fraction) mutable {
    const int tenth = int(fraction * 10.0 + 1e-9);
    if (tenth <= printed || fraction >= 1.0 || seconds_since(t0) < 1.0) return;
    printed = tenth;
    const double elapsed = seconds_since(t0);
    fmt::print(stderr, "{}: {:>3.0f}% of the images, {} so far, about {} left\n", name,
               100.0 * fraction, human_seconds(elapsed),
               human_seconds(elapsed * (1.0 - fraction) / fraction));
  };
}

// The size to cut: --size, or for a range the crop search's best size.
SeamlessTileConfig cut_config(const BtfSource& src, const TileArguments& o) {
  TileSearchConfig s = parse_tile_search_size(o.size, "--size");
  SeamlessTileConfig c;
  c.width = s.max_width;
  c.height = s.max_height;
  if (s.min_width != s.max_width || s.min_height != s.max_height) {
    s.images = o.images;
    const Tile t = find_seamless_tile(src, s).tile;
    c.width = t.width;
    c.height = t.height;
  }
  c.overlap_x = c.overlap_y = o.overlap;
  return c;
}

struct MadeTileReport {
  SeamlessTile tile;
  WrapStatistics made, crop;
  Tile crop_tile;
  std::size_t written = 0;
  ImageFormat format = ImageFormat::kPng;
  double cut_seconds = 0.0, seconds = 0.0;
};

nlohmann::json wrap_json(const WrapStatistics& w) {
  return {{"wrap_ratio_median", w.median_ratio},
          {"wrap_ratio_p90", w.p90_ratio},
          {"cut_ratio", w.cut_ratio},
          {"images", w.images}};
}

void print_json(const MadeTileReport& r, const TileArguments& o) {
  const Tile& g = r.tile.region;
  const Tile& c = r.crop_tile;
  const nlohmann::json j = {{"output", o.out},
                            {"width", r.tile.width},
                            {"height", r.tile.height},
                            {"region", {g.x, g.y, g.width, g.height}},
                            {"overlap", {r.tile.overlap_x, r.tile.overlap_y}},
                            {"cut_levels_rms", r.tile.cost.cut_levels},
                            {"neighbour_levels_rms", r.tile.cost.neighbour_levels},
                            {"made", wrap_json(r.made)},
                            {"best_crop", wrap_json(r.crop)},
                            {"best_crop_tile", {c.x, c.y, c.width, c.height}},
                            {"images_written", r.written},
                            {"cut_seconds", r.cut_seconds},
                            {"seconds", r.seconds}};
  std::cout << j.dump() << "\n";
}

void print_report(const MadeTileReport& r, const TileArguments& o) {
  const SeamlessTile& t = r.tile;
  const Tile& c = r.crop_tile;
  fmt::print(
      "made a {} on {} images in {}\n"
      "  wrap: its step across the wrap is {:.2f} times the step between neighbouring pixels "
      "inside it (median over {} images; 90th percentile {:.2f}): {}\n"
      "  the best {}x{} crop ({},{}) wraps at {:.2f} times (90th percentile {:.2f}): {}\n"
      "  cut: where the cut joins pixels from two places they differ by {:.2f} levels RMS "
      "(blended across it over a few pixels), against {:.2f} between neighbouring pixels of the "
      "data; the largest steps of the tile "
      "repeated 2 x 2 (99th percentile) are {:.2f} times the data's own (above about 1.2 the "
      "cut would show as a line)\n"
      "wrote {} {} images to {} and seamless-tile.json (where each pixel came from) in {}\n"
      "fit it with: btfgmm fit {} ... (fit {} --tile auto:{}x{} makes the same tile where no "
      "crop repeats cleanly)\n",
      t.describe(), t.images, human_seconds(r.cut_seconds), r.made.median_ratio, r.made.images,
      r.made.p90_ratio, wrap_verdict(r.made.p90_ratio), c.width, c.height, c.x, c.y,
      r.crop.median_ratio, r.crop.p90_ratio, wrap_verdict(r.crop.p90_ratio), t.cost.cut_levels,
      t.cost.neighbour_levels, r.made.cut_ratio, r.written, to_string(r.format), o.out,
      human_seconds(r.seconds), o.out, o.input, t.width, t.height);
}

}  // namespace

void run_made_tile(const TileArguments& o) {
  if (o.top > 1)
    throw Error(Error::Kind::kArgument,
                "--top lists crops and -o makes one tile; give one of them");
  const BtfSource src = BtfSource::open(o.input);
  SeamlessTileConfig c = cut_config(src, o);
  check_output_folder(o.out, o.overwrite);
  StopOnSignals signals;
  const auto t0 = Clock::now();
  c.progress = progress_lines("cut", o.quiet || o.json);
  c.stopped = [] { return g_stop.load(); };
  MadeTileReport r;
  r.tile = cut_seamless_tile(src, c);
  r.cut_seconds = seconds_since(t0);
  const BtfSource made = seamless_tile_source(src, r.tile);
  r.made = wrap_statistics(made, {}, o.images, &src);
  r.crop_tile = find_seamless_tile(src, r.tile.width, r.tile.height).tile;
  r.crop = wrap_statistics(src, r.crop_tile, o.images, &src);
  ConvertOptions w;
  if (o.format == "png") w.format = ImageFormat::kPng;
  if (o.format == "exr") w.format = ImageFormat::kExr;
  w.progress = progress_lines("write", o.quiet || o.json);
  w.stopped = c.stopped;
  const ConvertResult written = convert_to_utia(made, {}, o.out, w);
  write_text(std::filesystem::path(o.out) / "seamless-tile.json",
             seamless_tile_json(r.tile, src.info()), "seamless tile's pixel map");
  r.written = written.images;
  r.format = written.format;
  r.seconds = seconds_since(t0);
  if (o.json) return print_json(r, o);
  print_report(r, o);
}

}  // namespace btfgmm::cli
