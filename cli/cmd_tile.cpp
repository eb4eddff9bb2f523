// btfgmm tile: the tile of a BTF that repeats with the least visible seams: the best crop, or
// with -o a seamless tile cut along the seams of least error and written as a BTF.
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/tile.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "tile_command.hpp"

namespace btfgmm::cli {
namespace {

// What a seam error means for a tile repeated on a surface, in words.
const char* seam_verdict(double error) {
  if (error < 0.5) return "the seam is hard to see";
  if (error < 1.0) return "a faint seam, less than neighbouring pixels differ";
  if (error < 2.0)
    return "a visible seam (more than neighbouring pixels differ): no crop of this size repeats "
           "cleanly; -o TILE/ makes one that does, cut along the seams of least error";
  return "a plain seam: no crop of this size repeats cleanly; -o TILE/ makes one that does, cut "
         "along the seams of least error";
}

nlohmann::json candidate_json(const btfgmm::TileCandidate& c) {
  const btfgmm::Tile& t = c.tile;
  return {{"tile", {t.x, t.y, t.width, t.height}},
          {"score", c.score},
          {"seam_error", c.seam.total},
          {"left_right", c.seam.left_right},
          {"top_bottom", c.seam.top_bottom},
          {"rms_levels", c.seam.rms_levels}};
}

void run_tile(const TileArguments& o) {
  if (!o.out.empty()) return run_made_tile(o);
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.input);
  btfgmm::TileSearchConfig c = btfgmm::parse_tile_search_size(o.size, "--size");
  c.images = o.images;
  c.top = o.top;
  const auto t0 = Clock::now();
  const btfgmm::TileSearchResult r = btfgmm::find_seamless_tile(src, c);
  const btfgmm::Tile& t = r.tile;
  if (o.json) {
    nlohmann::json j = candidate_json(r.ranked[0]);
    j["candidates"] = r.candidates;
    j["images"] = r.images;
    j["seconds"] = seconds_since(t0);
    if (o.top > 1) {
      j["ranked"] = nlohmann::json::array();
      for (const btfgmm::TileCandidate& k : r.ranked) j["ranked"].push_back(candidate_json(k));
    }
    std::cout << j.dump() << "\n";
    return;
  }
  if (o.top > 1) {
    fmt::print("{:>4}  {:<16} {:>7} {:>10} {:>10} {:>10}\n", "rank", "tile X,Y,W,H", "score",
               "seam error", "left-right", "top-bottom");
    for (std::size_t k = 0; k < r.ranked.size(); ++k) {
      const btfgmm::TileCandidate& e = r.ranked[k];
      fmt::print("{:>4}  {:<16} {:>7.3f} {:>10.3f} {:>10.3f} {:>10.3f}\n", k + 1,
                 fmt::format("{},{},{},{}", e.tile.x, e.tile.y, e.tile.width, e.tile.height),
                 e.score, e.seam.total, e.seam.left_right, e.seam.top_bottom);
    }
  } else {
    fmt::print("tile {},{},{},{}\n", t.x, t.y, t.width, t.height);
  }
  fmt::print(stderr,
             "seam error {:.3f} (left-right {:.3f}, top-bottom {:.3f}; 0 = repeats as the texture "
             "continues, 1 = as different as neighbouring pixels): {}; {:.2f} levels RMS; {} "
             "candidates on {} images in {}\n",
             r.seam.total, r.seam.left_right, r.seam.top_bottom, seam_verdict(r.seam.total),
             r.seam.rms_levels, r.candidates, r.images, human_seconds(seconds_since(t0)));
  if (r.seam.total < btfgmm::kSeamlessCropError)
    fmt::print(stderr, "fit it with: btfgmm fit {} --tile {},{},{},{} ...\n", o.input, t.x, t.y,
               t.width, t.height);
  else
    fmt::print(stderr,
               "fit a seamless tile of this size with: btfgmm fit {} --tile auto:{}x{} ... (it "
               "makes one; the crop itself: --tile {},{},{},{})\n",
               o.input, t.width, t.height, t.x, t.y, t.width, t.height);
}

}  // namespace

void register_tile_command(CLI::App& app, Commands& commands) {
  auto to = std::make_shared<TileArguments>();
  auto* t = app.add_subcommand(
      "tile",
      "Find the tile of a BTF that repeats with the least visible seams (for fit --tile), or "
      "with -o make a seamless one and write it as a BTF");
  t->add_option("input", to->input, "A BTF folder, Bonn .zip or Bonn .btf file")->required();
  t->add_option("--size", to->size,
                "Tile size WxH; W and H may be ranges, e.g. 20-28x24. The tile chosen has the "
                "lowest score: its seam error times its aspect ratio (longer side / shorter "
                "side), so near-square tiles are preferred; ties go to the larger tile")
      ->capture_default_str();
  t->add_option("--images", to->images,
                "(light, view) images to judge the seams on, spread over all; 0: all")
      ->capture_default_str();
  t->add_option("--top", to->top,
                "List the N best tiles, the best position of each of the N best sizes, with "
                "their scores")
      ->check(CLI::Range(std::size_t(1), std::size_t(1000)))
      ->capture_default_str();
  t->add_flag("--json", to->json, "The result as one JSON object");
  t->add_option(
      "-o,--output", to->out,
      "Make a seamless tile of --size (a range: the crop search's best size) and "
      "write it to this folder in the UTIA layout, with seamless-tile.json naming "
      "each pixel's source. It is cut from a region of the tile plus an overlap, one "
      "cut for all images, along the seams of least error. Time: one read of every "
      "image; memory: about 64 MB of images and four cost maps of the image's size in doubles");
  t->add_option("--overlap", to->overlap,
                "With -o: the columns and rows the cuts may wander through (2 to half the "
                "tile); 0: as many as the images allow, up to half the tile")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  t->add_option("--format", to->format,
                "With -o: png (8-bit) or exr (linear float); default: like the input")
      ->check(CLI::IsMember({"png", "exr"}));
  t->add_flag("--overwrite", to->overwrite, "With -o: replace images in a non-empty folder");
  t->add_flag("-q,--quiet", to->quiet, "With -o: no progress on stderr");
  commands.push_back({t, [to] { run_tile(*to); }});
}

}  // namespace btfgmm::cli
