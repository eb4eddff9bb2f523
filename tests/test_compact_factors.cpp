// The compact encoding of the methods' factors (methods/compact_factors.hpp, docs/FORMAT.md
// "Compact factors"): the step bound, the exact round trip, refusal of damaged blocks, files
// smaller than q8's at nearly q8's quality, and the files of format 6 still read.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/model_file.hpp"
#include "methods/compact_factors.hpp"
#include "methods/factors.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

using test::error_of;

// rows x (w * h * 3) values: smooth images (a few waves) with a little noise, as
// eigen-images and coefficient planes are.
std::vector<float> smooth_images(std::size_t rows, int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  std::vector<float> v;
  for (std::size_t r = 0; r < rows; ++r)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          v.push_back(
              float((1.0 + 0.2 * c) * std::sin(0.3 * x + 0.2 * y + double(r)) + 0.1 * double(r)) +
              noise(rng));
  return v;
}

std::vector<std::uint8_t> block_of(std::span<const float> q, std::size_t cols,
                                   detail::FactorLayout layout) {
  detail::ByteWriter w;
  detail::put_factors(w, q, cols, FactorEncoding::kCompact, layout);
  return w.bytes;
}

TEST(CompactFactors, WithinHalfAStepAndReadBackBitForBit) {
  const int w = 13, h = 9;
  const std::size_t rows = 4, cols = std::size_t(w * h * 3);
  const std::vector<float> v = smooth_images(rows, w, h, 5);
  std::vector<float> q = v;
  detail::quantise_factors(q, cols, FactorEncoding::kCompact);
  for (std::size_t r = 0; r < rows; ++r) {
    const auto [lo, hi] =
        std::minmax_element(v.begin() + long(r * cols), v.begin() + long((r + 1) * cols));
    const double step = detail::compact_step(*lo, *hi);
    // A power of two, no coarser than twice q8's step and no finer than q8's.
    EXPECT_EQ(std::exp2(std::round(std::log2(step))), step);
    EXPECT_LE(step, 2.0 * (*hi - *lo) / 255.0);
    EXPECT_GT(step, (*hi - *lo) / 255.0);
    const double bound = detail::factor_error_bound(FactorEncoding::kCompact, *lo, *hi);
    EXPECT_NEAR(bound, step / 2.0, 1e-6 * step);
    for (std::size_t c = 0; c < cols; ++c)
      EXPECT_LE(std::abs(double(q[r * cols + c]) - double(v[r * cols + c])), bound);
  }
  for (const detail::FactorLayout layout :
       {detail::FactorLayout{std::size_t(w), 3}, detail::FactorLayout{0, 1},
        detail::FactorLayout{5, 3}}) {
    const std::vector<std::uint8_t> bytes = block_of(q, cols, layout);
    detail::ByteReader r(bytes, "model file", "f.btfgmm", "fit again");
    const std::vector<float> back = detail::get_factors(r, rows, cols, "factors", layout);
    EXPECT_EQ(r.remaining(), 0u);
    ASSERT_EQ(back.size(), q.size());
    EXPECT_EQ(std::memcmp(back.data(), q.data(), q.size() * 4), 0);
  }
  // Predicted from the pixels' neighbours, smooth images take fewer bytes than q8 stores.
  detail::ByteWriter q8;
  std::vector<float> v8 = v;
  detail::quantise_factors(v8, cols, FactorEncoding::kQ8);
  detail::put_factors(q8, v8, cols, FactorEncoding::kQ8);
  EXPECT_LT(block_of(q, cols, {std::size_t(w), 3}).size(), q8.bytes.size() * 3 / 4);
  // Rows of zeros and of one value; values not on a step are refused, not stored wrongly.
  std::vector<float> flat(2 * cols, 0.0f);
  std::fill(flat.begin() + long(cols), flat.end(), -3.7f);
  detail::quantise_factors(flat, cols, FactorEncoding::kCompact);
  const std::vector<std::uint8_t> fb = block_of(flat, cols, {std::size_t(w), 3});
  detail::ByteReader fr(fb, "model file", "f.btfgmm", "fit again");
  EXPECT_EQ(detail::get_factors(fr, 2, cols, "factors", {std::size_t(w), 3}), flat);
  const std::vector<float> wild = {1e30f, 1e-30f, 1.0f};
  EXPECT_NE(error_of([&] { block_of(wild, 3, {}); }).find("not quantised"), std::string::npos);
  EXPECT_EQ(parse_factor_encoding("compact", "--precision"), FactorEncoding::kCompact);
  EXPECT_EQ(to_string(FactorEncoding::kCompact), "compact");
}

// Every truncation of a compact block, and every single-byte change, is refused with an
// Error naming the field (or, for a change the codes survive, read as values); never a crash.
TEST(CompactFactors, TruncatedOrCorruptedBlocksAreRefused) {
  const int w = 6, h = 5;
  const std::size_t rows = 3, cols = std::size_t(w * h * 3);
  std::vector<float> q = smooth_images(rows, w, h, 9);
  detail::quantise_factors(q, cols, FactorEncoding::kCompact);
  const detail::FactorLayout layout{std::size_t(w), 3};
  const std::vector<std::uint8_t> bytes = block_of(q, cols, layout);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + long(n));
    detail::ByteReader r(cut, "model file", "f.btfgmm", "fit again");
    try {
      detail::get_factors(r, rows, cols, "eigen-images", layout);
      ADD_FAILURE() << "a block cut to " << n << " bytes was read";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), Error::Kind::kFormat);
      const std::string msg = e.what();
      EXPECT_NE(msg.find("f.btfgmm"), std::string::npos) << msg;
      EXPECT_TRUE(msg.find("eigen-images") != std::string::npos ||
                  msg.find("compressed codes") != std::string::npos)
          << msg;
    }
  }
  int refused = 0;
  for (std::size_t i = 9; i < bytes.size(); ++i)
    for (std::uint8_t flip : {std::uint8_t(1), std::uint8_t(0x80), std::uint8_t(0xff)}) {
      std::vector<std::uint8_t> bad = bytes;
      bad[i] ^= flip;
      detail::ByteReader r(bad, "model file", "f.btfgmm", "fit again");
      try {
        const std::vector<float> v = detail::get_factors(r, rows, cols, "eigen-images", layout);
        EXPECT_EQ(v.size(), q.size());
        for (float x : v) EXPECT_TRUE(std::isfinite(x));
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), Error::Kind::kFormat) << e.what();
        ++refused;
      }
    }
  EXPECT_GT(refused, 0);
  // A block that claims far more values than its compressed bytes can hold is refused
  // before anything is allocated for them.
  detail::ByteReader r(bytes, "model file", "f.btfgmm", "fit again");
  const std::string msg =
      error_of([&] { detail::get_factors(r, 100000, 100000, "eigen-images", layout); });
  EXPECT_NE(msg.find("eigen-images"), std::string::npos) << msg;
}

double psnr_of(const Representation& m, const Btf& tile) {
  const ModelFrame& f = m.frame();
  const Btf d = m.decode(f.lights, f.views, f.width, f.height, 0.0);
  double se = 0.0;
  for (std::size_t i = 0; i < tile.data().size(); ++i)
    se += (double(d.data()[i]) - double(tile.data()[i])) *
          (double(d.data()[i]) - double(tile.data()[i]));
  return 20.0 * std::log10(255.0 / std::sqrt(se / double(tile.data().size())));
}

// Every factor method's default file is compact, smaller than its q8 file on a generated
// tile, and as good within 0.1 dB where the model's own error dominates (small sizes: at
// nearly full rank the tile is reproduced to 60 dB, and twice q8's step shows); it reads back
// to the same bytes.
TEST(CompactFactors, EachMethodsCompactFileIsSmallerThanItsQ8File) {
  for (const char* material : {"knit", "corduroy"}) {
    const Btf tile = test::generated_tile(material, 12, 3, "rings:0/1,30/5,60/5", "rings:0/1,45/3");
    for (const char* name : {"pca-btf", "pca-rf", "lpca", "ptm-rf", "plm-rf"}) {
      SCOPED_TRACE(std::string(material) + " " + name);
      const MethodInfo& method = find_method(name);
      EXPECT_EQ(default_file_encoding(method), FactorEncoding::kCompact);
      FitOptions s;
      const bool pca = std::string(name).find("pca") != std::string::npos;
      s.components = pca ? 2 : 0;
      s.clusters = std::string(name) == "lpca" ? 2 : 0;
      s.precision = FactorEncoding::kQ8;
      const auto q8 = method.fit(tile, s);
      s.precision = default_file_encoding(method);
      const auto compact = method.fit(tile, s);
      EXPECT_EQ(compact->encoding(), FactorEncoding::kCompact);
      const std::vector<std::uint8_t> bytes = representation_file_bytes(*compact);
      const std::size_t q8_bytes = representation_file_bytes(*q8).size();
      EXPECT_LT(bytes.size(), q8_bytes);
      EXPECT_GT(psnr_of(*compact, tile), psnr_of(*q8, tile) - 0.1);
      const auto back = read_representation(bytes, "m.btfgmm");
      EXPECT_EQ(representation_file_bytes(*back), bytes);
      EXPECT_EQ(back->encoding(), FactorEncoding::kCompact);
      const auto info = back->details();
      EXPECT_NE(std::find(info.begin(), info.end(),
                          std::pair<std::string, std::string>{"factor encoding", "compact"}),
                info.end());
    }
  }
}

std::vector<std::uint8_t> golden_bytes(const std::string& name) {
  std::ifstream in(std::filesystem::path(BTFGMM_TEST_DATA) / name, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Golden {
  const char* method;
  float measured[3], between[3];
};

// Reads `prefix`method.btfgmm of `version`: the method, its encoding, the same payload when
// written again, and the values it predicted when it was written (btfgmm eval of that
// version), at a measured pair and between directions.
void check_golden(const std::string& prefix, std::uint32_t version, FactorEncoding encoding,
                  std::span<const Golden> golden) {
  for (const Golden& g : golden) {
    SCOPED_TRACE(g.method);
    const std::string name = prefix + g.method + ".btfgmm";
    const std::vector<std::uint8_t> bytes = golden_bytes(name);
    const ModelFileContents file = open_model_file(bytes, name);
    EXPECT_EQ(file.version, version);
    const auto model = read_representation(bytes, name);
    EXPECT_EQ(model->method(), g.method);
    EXPECT_EQ(model->encoding(), encoding);
    const std::vector<std::uint8_t> payload = model->payload();
    EXPECT_TRUE(
        std::equal(payload.begin(), payload.end(), file.payload.begin(), file.payload.end()));
    const Query queries[] = {{.x = 1, .y = 2, .light = {40, 60}, .view = {40, 120}},
                             {.x = 2.5, .y = 0.25, .light = {25, 75}, .view = {10, 200}}};
    float rgb[6];
    model->predict(queries, rgb);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(rgb[c], g.measured[c], 1e-3) << c;
      EXPECT_NEAR(rgb[3 + c], g.between[c], 1e-3) << c;
    }
  }
}

// Files of format 6 (q8 factors, that version's default): `btfgmm generate --material knit
// --size 4 --seed 7 --lights rings:0/1,40/6 --views rings:0/1,40/3`, then `fit --method M`.
TEST(CompactFactors, VersionSixQ8FilesStillRead) {
  const Golden golden[] = {
      {"pca-btf", {116.262871f, 108.166397f, 93.972427f}, {125.812675f, 116.639732f, 102.133026f}},
      {"pca-rf", {116.174950f, 108.023338f, 94.077316f}, {125.766441f, 116.650787f, 102.033264f}},
      {"lpca", {116.119560f, 107.917908f, 94.001389f}, {125.816498f, 116.683289f, 102.098175f}},
      {"ptm-rf", {115.757355f, 107.429413f, 93.903107f}, {131.482590f, 122.045677f, 106.889290f}},
      {"plm-rf", {117.574532f, 109.429726f, 95.586861f}, {133.121307f, 123.677429f, 108.238310f}},
  };
  check_golden("golden_v6_", 6, FactorEncoding::kQ8, golden);
}

// Files of format 7, compact factors, of the same tile and fits.
TEST(CompactFactors, VersionSevenCompactFilesRead) {
  const Golden golden[] = {
      {"pca-btf", {115.891739f, 107.934204f, 93.749481f}, {125.773163f, 116.744659f, 102.095810f}},
      {"pca-rf", {116.039062f, 107.861328f, 94.383301f}, {125.755432f, 116.671677f, 102.061295f}},
      {"lpca", {116.243164f, 108.062500f, 94.120117f}, {125.751320f, 116.630295f, 102.066284f}},
      {"ptm-rf", {115.792717f, 107.445442f, 93.814087f}, {131.520599f, 121.970490f, 106.896797f}},
      {"plm-rf", {117.866760f, 109.283775f, 95.619041f}, {133.075897f, 123.611870f, 108.185631f}},
  };
  check_golden("golden_v7_", 7, FactorEncoding::kCompact, golden);
}

}  // namespace
}  // namespace btfgmm
