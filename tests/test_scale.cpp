// Fits that outgrow one machine: the compact sample set (8-bit data held as bytes, the
// residuals computed where they are used) and the fit split over processes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// A generated 8-bit BTF of 12 x 12 pixels and 7 x 7 directions written to a folder.
fs::path written_btf(const std::string& tag, bool hdr = false) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_scale_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  GenerateConfig g;
  g.material = "knit";
  g.size = 12;
  g.seed = 5;
  g.lights = g.views = DirectionSet::parse("rings:0/1,45/6");
  g.supersample = 1;
  g.hdr = hdr;
  write_utia(generate(g), dir);
  return dir;
}

// Read image by image, an 8-bit tile is held as 3 bytes a sample, and is the sample set of the
// tile loaded whole: the same levels, mean BRDF and residuals (bit for bit), the same content
// hash.
TEST(Scale, SampleSetReadImageByImageHoldsBytesAndEqualsTheLoadedTile) {
  const fs::path dir = written_btf("bytes");
  const BtfSource src = BtfSource::open(dir);
  const Tile tile{2, 3, 8, 6};
  std::uint64_t hash = 0;
  const SampleSet read = read_sample_set(src, tile, &hash);
  const Btf loaded = src.load(tile);
  const SampleSet whole = make_sample_set(loaded);
  EXPECT_EQ(hash, tile_content_hash(loaded));
  EXPECT_EQ(read.bytes_per_sample(), 3u);
  EXPECT_TRUE(read.residual.empty());
  EXPECT_EQ(read.levels.size(), read.size() * 3);
  EXPECT_EQ(read.levels, whole.levels);
  EXPECT_EQ(read.mean_brdf, whole.mean_brdf);
  EXPECT_EQ(read.scaling.unit, whole.scaling.unit);
  ASSERT_EQ(read.size(), 8u * 6u * 7u * 7u);
  std::size_t checked = 0;
  for (std::size_t p = 0; p < read.pixels(); ++p)
    for (std::size_t l = 0; l < read.lights; ++l)
      for (std::size_t v = 0; v < read.views; ++v)
        for (int c = 0; c < 3; ++c) {
          const int x = int(p % 8), y = int(p / 8);
          const float expected = loaded.at(l, v, x, y, c) - read.mean_brdf[(l * 7 + v) * 3 + c];
          EXPECT_EQ(read.residual_of(read.index(p, l, v), c), expected);
          ++checked;
        }
  EXPECT_EQ(checked, read.size() * 3);
  fs::remove_all(dir);
}

// HDR data keeps float residuals, read through the same call, equal to the loaded tile's.
TEST(Scale, HdrSampleSetKeepsFloatResiduals) {
  const fs::path dir = written_btf("hdr", true);
  const BtfSource src = BtfSource::open(dir);
  std::uint64_t hash = 0;
  const SampleSet read = read_sample_set(src, {}, &hash);
  const Btf loaded = src.load();
  EXPECT_EQ(hash, tile_content_hash(loaded));
  EXPECT_EQ(read.bytes_per_sample(), 12u);
  EXPECT_EQ(read.residual, make_sample_set(loaded).residual);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
