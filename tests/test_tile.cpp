// The seamless-tile search: it finds the period of generated periodic textures, and its tile
// has a lower seam error than tiles cut elsewhere.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/measure/tile.hpp"

namespace {

using namespace btfgmm;

Btf periodic(const std::string& material, int size) {
  GenerateConfig g;
  g.material = material;
  g.size = size;
  g.seed = 9;
  g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
  g.views = DirectionSet::parse("rings:0/1,45/5");
  g.supersample = 1;
  return generate(g);
}

TEST(Tile, FindsTheWalePeriodOfCorduroy) {
  // Corduroy of 64 pixels has 8 wales of 8 pixels across x (with a small per-wale jitter).
  const Btf btf = periodic("corduroy", 64);
  TileSearchConfig c;
  c.min_width = 18;
  c.max_width = 30;
  c.min_height = c.max_height = 24;
  c.images = 16;
  const TileSearchResult r = find_seamless_tile(btf, c);
  EXPECT_EQ(r.tile.width % 8, 0) << "width " << r.tile.width;
  EXPECT_EQ(r.tile.height, 24);
  EXPECT_EQ(r.images, 16u);
  // Widths 18..30 at every x, one height at every y: 41 * (47 + 46 + ... + 35).
  EXPECT_EQ(r.candidates, 41u * 533u);
  // The found tile against tiles of the same size elsewhere and tiles of other widths.
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> w(18, 30), pos(0, 64 - 31);
  int worse = 0;
  for (int i = 0; i < 40; ++i) {
    const Tile t{.x = pos(rng), .y = pos(rng), .width = w(rng), .height = 24};
    const SeamError e = seam_error(btf, t, 16);
    EXPECT_GE(e.total, r.seam.total);
    worse += t.width % 8 != 0 && e.total > 2.0 * r.seam.total;
  }
  EXPECT_GT(worse, 20);  // most tiles off the period are clearly worse
  const SeamError again = seam_error(btf, r.tile, 16);
  EXPECT_DOUBLE_EQ(again.total, r.seam.total);
  EXPECT_LT(r.seam.left_right, 0.5);
}

TEST(Tile, FindsBothPeriodsOfKnit) {
  // Knit of 40 pixels: 4 x 4 stitches of 10 pixels.
  const Btf btf = periodic("knit", 40);
  TileSearchConfig c;
  c.min_width = c.min_height = 13;
  c.max_width = c.max_height = 27;
  c.images = 16;
  const TileSearchResult r = find_seamless_tile(btf, c);
  EXPECT_EQ(r.tile.width, 20);
  EXPECT_EQ(r.tile.height, 20);
  EXPECT_EQ(r.images, 16u);
  const SeamError off =
      seam_error(btf, {.x = r.tile.x + 3, .y = r.tile.y, .width = 17, .height = 20}, 16);
  EXPECT_GT(off.left_right, 3.0 * r.seam.left_right);
}

// The first `width` columns of every image: a BTF that no longer tiles across x.
Btf first_columns(const Btf& btf, int width) {
  Btf out(btf.lights(), btf.views(), width, btf.height(), btf.format());
  for (std::size_t l = 0; l < btf.lights().size(); ++l)
    for (std::size_t v = 0; v < btf.views().size(); ++v)
      for (int y = 0; y < btf.height(); ++y)
        for (int x = 0; x < width; ++x)
          for (int c = 0; c < 3; ++c) out.at(l, v, x, y, c) = btf.at(l, v, x, y, c);
  return out;
}

TEST(Tile, TheWholeImageIsATileJudgedAcrossItsWrap) {
  // Generated knit repeats across its whole 40 pixels: as a tile, the whole image is seamless.
  const Btf btf = periodic("knit", 40);
  TileSearchConfig c;
  c.min_width = c.max_width = c.min_height = c.max_height = 40;
  c.images = 16;
  const TileSearchResult r = find_seamless_tile(btf, c);
  EXPECT_EQ(r.tile.x, 0);
  EXPECT_EQ(r.tile.width, 40);
  EXPECT_LT(r.seam.total, 0.2);
  // Cut to 35 columns (3.5 stitches), the step across its wrap is a seam, and a 20-pixel tile
  // (two stitches) inside it beats the whole image.
  const Btf cut = first_columns(btf, 35);
  const SeamError whole = seam_error(cut, {.x = 0, .y = 0, .width = 35, .height = 40}, 16);
  EXPECT_GT(whole.left_right, 1.0);
  EXPECT_LT(whole.top_bottom, 0.2);
  c.min_width = 18;
  c.max_width = 35;
  c.min_height = c.max_height = 40;
  const TileSearchResult inside = find_seamless_tile(cut, c);
  EXPECT_EQ(inside.tile.width % 10, 0) << inside.tile.width;
  EXPECT_LT(inside.seam.total, whole.total);
  c.max_width = 36;  // past the image: refused, naming the limit
  try {
    find_seamless_tile(cut, c);
    ADD_FAILURE() << "a tile wider than the image was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no larger than the image"), std::string::npos)
        << e.what();
  }
}

TEST(Tile, PrefersNearSquareTilesAndRanksTheBestSizes) {
  // Leather has no period shorter than the image: over 8-24 x 8-24 the seam error alone picks
  // a 16 x 8 strip here (seam error 0.374, against 0.458 for the 8 x 8 tile the score picks).
  const Btf btf = periodic("leather", 48);
  TileSearchConfig c;
  c.min_width = c.min_height = 8;
  c.max_width = c.max_height = 24;
  c.images = 16;
  c.top = 5;
  const TileSearchResult r = find_seamless_tile(btf, c);
  const Tile& t = r.tile;
  EXPECT_LE(double(std::max(t.width, t.height)) / std::min(t.width, t.height), 1.25)
      << t.width << "x" << t.height;
  ASSERT_EQ(r.ranked.size(), 5u);
  EXPECT_EQ(r.ranked[0].tile.width, t.width);
  EXPECT_EQ(r.ranked[0].tile.height, t.height);
  EXPECT_DOUBLE_EQ(r.score, r.ranked[0].score);
  for (std::size_t k = 0; k < r.ranked.size(); ++k) {
    const TileCandidate& e = r.ranked[k];
    const double aspect =
        double(std::max(e.tile.width, e.tile.height)) / std::min(e.tile.width, e.tile.height);
    EXPECT_DOUBLE_EQ(e.score, e.seam.total * aspect) << k;
    EXPECT_DOUBLE_EQ(tile_score(e.seam, e.tile.width, e.tile.height), e.score) << k;
    if (k > 0) {
      EXPECT_LE(r.ranked[k - 1].score, e.score) << k;
    }
    for (std::size_t i = 0; i < k; ++i)  // one entry a size
      EXPECT_FALSE(r.ranked[i].tile.width == e.tile.width &&
                   r.ranked[i].tile.height == e.tile.height)
          << k;
    // The best position of its size.
    EXPECT_DOUBLE_EQ(seam_error(btf, e.tile, 16).total, e.seam.total) << k;
  }
}

TEST(Tile, ParsesSizesAndRejectsNonsense) {
  TileSearchConfig c = parse_tile_search_size("20-28x24", "--size");
  EXPECT_EQ(c.min_width, 20);
  EXPECT_EQ(c.max_width, 28);
  EXPECT_EQ(c.min_height, 24);
  EXPECT_EQ(c.max_height, 24);
  c = parse_tile_search_size("32x16", "--size");
  EXPECT_EQ(c.max_width, 32);
  EXPECT_EQ(c.min_height, 16);
  for (const char* bad : {"32", "x4", "28-20x4", "0x4", "ax4", "4x4-"}) {
    try {
      parse_tile_search_size(bad, "--size");
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), Error::Kind::kArgument);
      EXPECT_NE(std::string(e.what()).find("--size"), std::string::npos) << e.what();
    }
  }
  const Btf btf = periodic("bumps", 16);
  TileSearchConfig whole;
  whole.min_width = whole.max_width = 17;  // wider than the image
  whole.min_height = whole.max_height = 8;
  EXPECT_THROW(find_seamless_tile(btf, whole), Error);
  EXPECT_THROW(seam_error(btf, {.x = 10, .y = 0, .width = 8, .height = 8}), Error);  // outside
}

}  // namespace
