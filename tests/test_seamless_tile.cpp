// Seamless tiles made by cutting (measure/seamless_tile.hpp): the cut goes where the strips
// agree (a known answer), the made tile's pixels are the blends its map names, its wrap is a
// step between neighbours of the data, it repeats better than the best crop of a texture that
// does not repeat, the cut is the same on any number of threads and made again from its
// description, and sizes the image cannot hold get an error naming the largest that it can.
#include <gtest/gtest.h>
#include <omp.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/utia.hpp"
#include "btfgmm/measure/seamless_tile.hpp"
#include "btfgmm/measure/tile.hpp"
#include "btfgmm/measure/tile_option.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/fit.hpp"
#include "test_util.hpp"

namespace {

using namespace btfgmm;
namespace fs = std::filesystem;

// A folder of the test's own, removed afterwards.
class Folder {
 public:
  explicit Folder(const std::string& tag)
      : path_(fs::temp_directory_path() /
              ("btfgmm_seamless_" + tag + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Folder() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// Noise of 8-bit levels that repeats nowhere, smoothed over 2 pixels so that neighbours are
// alike as in a real texture: `images` images of w x h.
Btf noise(int w, int h, std::uint32_t seed) {
  Btf b(DirectionSet::parse("rings:0/1,30/2"), DirectionSet::parse("rings:0/1"), w, h,
        SampleFormat::kLdr8);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 255.0f);
  for (std::size_t l = 0; l < b.lights().size(); ++l) {
    std::vector<float> raw(std::size_t(w) * h * 3);
    for (float& v : raw) v = u(rng);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          float s = 0;
          for (int d = 0; d < 2; ++d)
            s += raw[(std::size_t(y) * w + std::min(x + d, w - 1)) * 3 + c] +
                 raw[(std::size_t(std::min(y + d, h - 1)) * w + x) * 3 + c];
          b.at(l, 0, x, y, c) = std::round(s / 4.0f);
        }
  }
  return b;
}

// The data on disk as the commands read it.
BtfSource written(const Btf& b, const std::string& folder) {
  write_utia(b, folder);
  return BtfSource::open(folder);
}

TEST(SeamlessTile, TheCutsGoWhereTheOppositeStripsAgree) {
  // A 24 x 24 tile with an overlap of 12 from the region at (2, 3) of 40 x 40 images. The strip
  // a tile's width to the right equals the overlap's columns 5 and 6 and the strip a tile's
  // height below its rows 4 and 5: the cut between 5 and 6 (p = 6) costs nothing, every other
  // one something, and the same for the rows (q = 5).
  Btf b = noise(40, 40, 1);
  const int x0 = 2, y0 = 3, W = 24, H = 24;
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (int c = 0; c < 3; ++c) {
      for (int x = 0; x < 40; ++x)
        for (int i : {4, 5}) b.at(l, 0, x, y0 + i + H, c) = b.at(l, 0, x, y0 + i, c);
      for (int y = 0; y < 40; ++y)
        for (int j : {5, 6}) b.at(l, 0, x0 + j + W, y, c) = b.at(l, 0, x0 + j, y, c);
    }
  Folder dir("agree");
  const BtfSource src = written(b, dir / "btf");
  SeamlessTileConfig c;
  c.width = W;
  c.height = H;
  c.overlap_x = c.overlap_y = 12;
  c.at = std::pair(x0, y0);
  const SeamlessTile t = cut_seamless_tile(src, c);
  EXPECT_EQ(t.region.x, x0);
  EXPECT_EQ(t.region.width, W + 12);
  ASSERT_EQ(t.column_cut.size(), std::size_t(H));
  ASSERT_EQ(t.row_cut.size(), std::size_t(W));
  for (int p : t.column_cut) EXPECT_EQ(p, 6);
  for (int q : t.row_cut) EXPECT_EQ(q, 5);
  EXPECT_NEAR(t.cost.cut_levels, 0.0, 1e-9);
  EXPECT_GT(t.cost.neighbour_levels, 5.0);
  EXPECT_EQ(t.images, b.image_count());
  // Searched over every position, the cut finds the same columns and rows of the image (at
  // whichever region holds them with room for the feather).
  c.at.reset();
  const SeamlessTile searched = cut_seamless_tile(src, c);
  EXPECT_NEAR(searched.cost.cut_levels, 0.0, 1e-9);
  EXPECT_EQ(searched.region.x + searched.column_cut[0], x0 + 6);
  EXPECT_EQ(searched.region.y + searched.row_cut[0], y0 + 5);
  EXPECT_EQ(searched.positions, std::size_t(40 - 36 + 1) * std::size_t(40 - 36 + 1));
}

TEST(SeamlessTile, ItsPixelsAreTheBlendsItsMapNamesAndItsWrapIsAStepOfTheData) {
  const Btf b = noise(30, 28, 2);
  Folder dir("blend");
  const BtfSource src = written(b, dir / "btf");
  SeamlessTileConfig c;
  c.width = 20;
  c.height = 18;
  const SeamlessTile t = cut_seamless_tile(src, c);
  EXPECT_EQ(t.overlap_x, 10);  // as many as fit, up to half the tile
  EXPECT_EQ(t.overlap_y, 9);
  const PixelMap m = t.pixel_map(t.describe());
  ASSERT_EQ(m.source.size(), std::size_t(20 * 18));
  for (const auto& taps : m.source) {
    float sum = 0;
    for (const PixelTap& tap : taps) sum += tap.weight;
    EXPECT_NEAR(sum, 1.0f, 1e-6f);
  }
  const Btf made = seamless_tile_source(src, t).load();
  EXPECT_EQ(made.width(), 20);
  EXPECT_EQ(made.height(), 18);
  EXPECT_EQ(made.made_from(), t.describe());
  const int x0 = t.region.x, y0 = t.region.y;
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (int y = 0; y < 18; ++y)
      for (int x = 0; x < 20; ++x)
        for (int ch = 0; ch < 3; ++ch) {
          double want = 0;
          for (const PixelTap& tap : m.source[std::size_t(y) * 20 + x])
            want += tap.weight * b.at(l, 0, x0 + tap.dx, y0 + tap.dy, ch);
          ASSERT_NEAR(made.at(l, 0, x, y, ch), std::round(want), 0.5 + 1e-3) << x << "," << y;
          // Past the overlaps the tile is the region's own pixels; its first column and row
          // continue its last ones as the data does (the pixel a tile's width / height on).
          if (x >= t.overlap_x && y >= t.overlap_y) {
            ASSERT_EQ(made.at(l, 0, x, y, ch), b.at(l, 0, x0 + x, y0 + y, ch));
          }
          if (x == 0 && y >= t.overlap_y) {
            ASSERT_EQ(made.at(l, 0, 0, y, ch), b.at(l, 0, x0 + 20, y0 + y, ch));
          }
          if (y == 0 && x >= t.overlap_x) {
            ASSERT_EQ(made.at(l, 0, x, 0, ch), b.at(l, 0, x0 + x, y0 + 18, ch));
          }
        }
  // The map beside the images, as JSON: each pixel's taps in source coordinates.
  const auto j = nlohmann::json::parse(seamless_tile_json(t, src.info()));
  EXPECT_EQ(j["pixels"].size(), std::size_t(20 * 18));
  EXPECT_EQ(j["region"][0], x0);
  const auto& last = j["pixels"][20 * 18 - 1];
  ASSERT_EQ(last.size(), 1u);
  EXPECT_EQ(last[0][0], x0 + 19);
  EXPECT_EQ(last[0][2], 1.0);
}

TEST(SeamlessTile, RepeatsBetterThanTheBestCropOfATextureThatDoesNotRepeat) {
  const Btf b = noise(32, 32, 3);
  Folder dir("better");
  const BtfSource src = written(b, dir / "btf");
  SeamlessTileConfig c;
  c.width = c.height = 20;
  const SeamlessTile t = cut_seamless_tile(src, c);
  const WrapStatistics made = wrap_statistics(seamless_tile_source(src, t), {}, 64, &src);
  TileSearchConfig s;
  s.min_width = s.max_width = s.min_height = s.max_height = 20;
  const TileSearchResult crop = find_seamless_tile(src, s);
  const WrapStatistics cropped = wrap_statistics(src, crop.tile, 64, &src);
  EXPECT_EQ(made.images, b.image_count());
  // Steps across a wrap between unrelated pixels are larger than between neighbours.
  EXPECT_GT(cropped.median_ratio, 1.2);
  EXPECT_LT(made.median_ratio, 1.1);
  EXPECT_LT(made.p90_ratio, cropped.p90_ratio);
  EXPECT_LT(made.cut_ratio, 1.3);
  // auto: cuts where no crop repeats: the chosen data is the made tile.
  const TileChoice choice = choose_tile(src, "auto:20x20");
  ASSERT_TRUE(choice.cut);
  EXPECT_EQ(choice.cut->describe(), t.describe());
  EXPECT_EQ(choice.source.info().width, 20);
}

TEST(SeamlessTile, TheSameOnAnyNumberOfThreadsAndMadeAgainFromItsDescription) {
  const Btf b = noise(34, 30, 4);
  Folder dir("again");
  const BtfSource src = written(b, dir / "btf");
  SeamlessTileConfig c;
  c.width = 22;
  c.height = 20;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const SeamlessTile one = cut_seamless_tile(src, c);
  omp_set_num_threads(std::max(threads, 3));
  const SeamlessTile many = cut_seamless_tile(src, c);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.describe(), many.describe());
  EXPECT_EQ(one.column_cut, many.column_cut);
  EXPECT_EQ(one.row_cut, many.row_cut);
  EXPECT_EQ(one.cost.cut_levels, many.cost.cut_levels);
  const SeamlessTile again = made_tile_again(src, one.describe());
  EXPECT_EQ(again.region.x, one.region.x);
  EXPECT_EQ(again.region.y, one.region.y);
  EXPECT_EQ(again.column_cut, one.column_cut);
  EXPECT_EQ(again.row_cut, one.row_cut);
  EXPECT_EQ(again.positions, 1u);
  const std::string bad = test::error_of([&] { made_tile_again(src, "0,0,22,20"); });
  EXPECT_NE(bad.find("names no seamless tile"), std::string::npos) << bad;
  const std::string outside = test::error_of(
      [&] { made_tile_again(src, "seamless 22x20 tile cut from 9,0,33,30 (overlap 11x10)"); });
  EXPECT_NE(outside.find("not inside"), std::string::npos) << outside;
}

TEST(SeamlessTile, SizesTheImageCannotHoldNameTheLargestItCan) {
  const Btf b = noise(16, 16, 5);
  Folder dir("small");
  const BtfSource src = written(b, dir / "btf");
  SeamlessTileConfig c;
  c.width = c.height = 15;
  std::string e = test::error_of([&] { cut_seamless_tile(src, c); });
  EXPECT_NE(e.find("at most 14x14"), std::string::npos) << e;
  EXPECT_NE(e.find(src.info().path.string()), std::string::npos) << e;
  c.width = c.height = 3;
  e = test::error_of([&] { cut_seamless_tile(src, c); });
  EXPECT_NE(e.find("at least 4x4"), std::string::npos) << e;
  c.width = c.height = 10;
  c.overlap_x = 6;
  e = test::error_of([&] { cut_seamless_tile(src, c); });
  EXPECT_NE(e.find("more than half"), std::string::npos) << e;
  // Stopped between batches: an error that says so, nothing made.
  c.overlap_x = 0;
  c.stopped = [] { return true; };
  e = test::error_of([&] { cut_seamless_tile(src, c); });
  EXPECT_NE(e.find("stopped"), std::string::npos) << e;
}

}  // namespace

namespace {

TEST(SeamlessTile, ACheckpointKeepsTheMadeTile) {
  FitCheckpoint k;
  k.input = "btf";
  k.output = "m.btfgmm";
  k.made_from = "seamless 20x20 tile cut from 1,2,30,30 (overlap 10x10)";
  k.state.mixture.resize(1);
  const fs::path path = fs::temp_directory_path() / "btfgmm_seamless_made.ckpt";
  save_checkpoint(k, path);
  const FitRequest r = resume_request(path);
  fs::remove(path);
  EXPECT_EQ(r.made_tile, k.made_from);
}

#ifdef BTFGMM_CLI_PATH
// tile -o writes the made tile and its map, refuses to write over images, and a model of it
// (fit --tile auto:) goes on (fit --continue) on the tile made again.
TEST(SeamlessTileCli, TileWritesItAndAFitOfItGoesOn) {
  Folder dir("cli");
  write_utia(noise(30, 30, 6), dir / "btf");
  test::CliRun r =
      test::run_cli("tile " + (dir / "btf") + " --size 20x20 -o " + (dir / "made"), "seamless");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("made a seamless 20x20 tile cut from"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrap: its step across the wrap is"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir / "made/seamless-tile.json"));
  EXPECT_EQ(BtfSource::open(dir / "made").info().width, 20);
  r = test::run_cli("tile " + (dir / "btf") + " --size 20x20 -o " + (dir / "made"), "seamless");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  r = test::run_cli("tile " + (dir / "btf") + " --size 29x20 -o " + (dir / "other"), "seamless");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("at most 28x28"), std::string::npos) << r.err;

  r = test::run_cli(
      "fit " + (dir / "btf") + " --tile auto:20x20 -M 4 --iterations 2 -q -o " + (dir / "a.btfgmm"),
      "seamless");
  ASSERT_EQ(r.status, 0) << r.err;
  r = test::run_cli(
      "fit --continue " + (dir / "a.btfgmm") + " --iterations 3 -q -o " + (dir / "b.btfgmm"),
      "seamless");
  ASSERT_EQ(r.status, 0) << r.err;
  r = test::run_cli("info --json " + (dir / "b.btfgmm"), "seamless");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("seamless 20x20 tile cut from"), std::string::npos) << r.out;
  r = test::run_cli("info " + (dir / "b.btfgmm"), "seamless");
  EXPECT_NE(r.out.find("(its seamless 20x20 tile cut from"), std::string::npos) << r.out;
  r = test::run_cli("compare " + (dir / "btf") + " " + (dir / "b.btfgmm") + " --json -q",
                    "seamless");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["data_match"], "same");
}
#endif

}  // namespace
