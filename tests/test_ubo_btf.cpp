// Bonn .btf files: files written by the tests' own writer (ubo_btf_writer.hpp, after btflib's
// published writers) from known images, read back by the reader (io/ubo_btf.hpp) through the
// data-set opening every command uses, `convert` and `info`; and every kind of bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/convert.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/io/ubo_btf.hpp"
#include "btfgmm/measure/seamless_tile.hpp"
#include "btfgmm/measure/tile.hpp"
#include "test_util.hpp"
#include "ubo_btf_writer.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using test::UboAngles;
using test::UboSpec;

constexpr float kDeg = float(std::numbers::pi / 180.0);

// 5 lights (one with a negative azimuth, as angles in radians may be) x 4 views, w x h pixels.
UboSpec small_spec(bool dfmf, std::uint32_t w = 8, std::uint32_t h = 6) {
  UboSpec s;
  s.dfmf = dfmf;
  s.lights = {{0, 0},
              {30 * kDeg, 0},
              {30 * kDeg, 180 * kDeg},
              {60 * kDeg, -90 * kDeg},
              {75 * kDeg, 45 * kDeg}};
  s.views = {{0, 0}, {45 * kDeg, 90 * kDeg}, {45 * kDeg, 270 * kDeg}, {70 * kDeg, 10 * kDeg}};
  s.width = w;
  s.height = h;
  return s;
}

// Known linear images, light-major: a lobe over the directions times a texture, positive.
std::vector<float> known_images(const UboSpec& s) {
  const std::size_t nl = s.lights.size(), nv = s.views.size();
  std::vector<float> img;
  for (std::size_t l = 0; l < nl; ++l)
    for (std::size_t v = 0; v < nv; ++v)
      for (std::uint32_t y = 0; y < s.height; ++y)
        for (std::uint32_t x = 0; x < s.width; ++x)
          for (int c = 0; c < 3; ++c) {
            const double lobe = 0.2 + 0.6 * std::cos(s.lights[l].theta) *
                                          (1.0 + 0.3 * std::cos(s.views[v].phi - s.lights[l].phi));
            const double tex =
                0.6 + 0.4 * std::sin(0.7 * x + 1.3 * y + c) * std::cos(0.4 * double(v));
            img.push_back(float(lobe * tex * (0.7 + 0.15 * c)));
          }
  return img;
}

fs::path write_file(const std::vector<std::uint8_t>& bytes, const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("btfgmm_ubo_" + name);
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return p;
}

// Half-float precision at full rank: with U orthogonal, sum_k |u_k sxv_k| <= the norm of the
// pixel's column over all pairs, and each product carries at most 2 x 2^-11 relative rounding.
double column_norm(const std::vector<float>& stored, std::size_t pairs, std::size_t px,
                   std::size_t p, int c) {
  double n = 0;
  for (std::size_t i = 0; i < pairs; ++i) n += std::pow(stored[(i * px + p) * 3 + c], 2);
  return std::sqrt(n);
}

TEST(UboBtf, DfmfRgbFullRankReproducesTheImagesWithinHalfPrecision) {
  const UboSpec s = small_spec(true);
  const std::vector<float> images = known_images(s);
  const fs::path p = write_file(test::write_ubo_btf_images(s, images), "rgb.btf");
  const BtfSource src = BtfSource::open(p);
  EXPECT_EQ(src.info().layout, Layout::kUboBtf);
  EXPECT_EQ(src.info().format, SampleFormat::kHdr);
  const Btf btf = src.load();
  const std::size_t px = std::size_t(s.width) * s.height, pairs = 20;
  ASSERT_EQ(btf.data().size(), images.size());
  double worst = 0;
  for (std::size_t i = 0; i < pairs; ++i)
    for (std::size_t q = 0; q < px; ++q)
      for (int c = 0; c < 3; ++c) {
        const double bound = 1.05 * std::ldexp(1.0, -10) * column_norm(images, pairs, px, q, c);
        const double err =
            std::abs(btf.data()[(i * px + q) * 3 + c] - images[(i * px + q) * 3 + c]);
        worst = std::max(worst, err / bound);
      }
  EXPECT_LE(worst, 1.0) << "worst error over the half-precision bound";
  EXPECT_GT(worst, 1e-4) << "the file's factors are not half floats";
  fs::remove(p);
}

TEST(UboBtf, ColourModelElevenAndFmfWithLogAndCosineDecodeToTheImages) {
  for (const bool dfmf : {true, false}) {
    UboSpec s = small_spec(dfmf);
    s.colour_model = dfmf ? 11 : 0;
    s.dynamic_range = dfmf ? 0 : 1;
    s.cosine = true;
    const std::vector<float> images = known_images(s);
    const fs::path p = write_file(test::write_ubo_btf_images(s, images), "log.btf");
    const Btf btf = BtfSource::open(p).load();
    double worst = 0;
    for (std::size_t i = 0; i < images.size(); ++i)
      worst = std::max(worst, std::abs(double(btf.data()[i]) - images[i]) / images[i]);
    // log channels: an absolute half error of about 2^-10 |log v| becomes that relative error
    EXPECT_LE(worst, 0.02) << (dfmf ? "DFMF, Ylog U/Y V/Y" : "FMF, log");
    EXPECT_GT(worst, 1e-5);
    fs::remove(p);
  }
}

TEST(UboBtf, DirectionsAreTheFilesInItsOrderAndATileDecodesAlone) {
  const UboSpec s = small_spec(true);
  const fs::path p = write_file(test::write_ubo_btf_images(s, known_images(s)), "dirs.btf");
  const BtfSource src = BtfSource::open(p);
  ASSERT_EQ(src.info().lights.size(), 5u);
  ASSERT_EQ(src.info().views.size(), 4u);
  EXPECT_NEAR(src.info().lights[2].theta_deg, 30.0, 1e-4);
  EXPECT_NEAR(src.info().lights[2].phi_deg, 180.0, 1e-4);
  EXPECT_NEAR(src.info().lights[3].phi_deg, 270.0, 1e-4);  // -90 degrees, wrapped
  EXPECT_NEAR(src.info().views[3].theta_deg, 70.0, 1e-4);
  const Btf whole = src.load();
  const Tile t{.x = 3, .y = 2, .width = 4, .height = 3};
  const Btf tile = src.load(t);
  for (std::size_t l = 0; l < 5; ++l)
    for (std::size_t v = 0; v < 4; ++v)
      for (int y = 0; y < t.height; ++y)
        for (int x = 0; x < t.width; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(tile.at(l, v, x, y, c), whole.at(l, v, x + t.x, y + t.y, c));
  EXPECT_NE(test::error_of([&] { src.load({6, 0, 4, 2}); }).find("not inside"), std::string::npos);
  fs::remove(p);
}

// ---- bad input -------------------------------------------------------------------------

std::string open_error(const std::vector<std::uint8_t>& bytes) {
  return test::error_of([&] { UboBtf::from_bytes(bytes, "bad.btf"); });
}

TEST(UboBtf, BadInputGetsAClearErrorEach) {
  const UboSpec s = small_spec(true, 4, 3);
  const std::vector<std::uint8_t> good = test::write_ubo_btf_images(s, known_images(s));
  EXPECT_NO_THROW(UboBtf::from_bytes(good, "good.btf"));

  auto bytes = good;
  bytes[1] = 'X';
  EXPECT_NE(open_error(bytes).find("signature is '!XFMF08FCR'"), std::string::npos);
  std::copy_n("!BDIF06FCR", 10, bytes.begin());
  EXPECT_NE(open_error(bytes).find("a Bonn format btfgmm does not read"), std::string::npos);

  for (std::size_t cut : {5ul, 40ul, 300ul, good.size() / 2, good.size() - 1}) {
    const std::string e = open_error({good.begin(), good.begin() + std::ptrdiff_t(cut)});
    EXPECT_NE(e.find("the file ends inside"), std::string::npos) << cut << ": " << e;
  }
  bytes = good;
  bytes.push_back(0);
  EXPECT_NE(open_error(bytes).find("1 bytes follow the last section"), std::string::npos);

  bytes = good;
  bytes[10] += 4;  // the metadata's size
  EXPECT_NE(open_error(bytes).find("metadata's size field says"), std::string::npos);

  // the second view lists one light more than the first
  std::uint32_t meta = 0;
  std::memcpy(&meta, &good[10], 4);
  const std::size_t second_count = 10 + meta + 4 + 12 + 8 * s.lights.size() + 8;
  bytes = good;
  bytes[second_count] += 1;
  EXPECT_NE(open_error(bytes).find("view 1 lists 6 lights but view 0 lists 5"), std::string::npos);
}

TEST(UboBtf, FactorsThatDisagreeOrAreNotFiniteAreRefused) {
  const UboSpec s = small_spec(true, 4, 3);
  auto factors = [&] {
    std::vector<test::UboFactors> f(3);
    for (auto& m : f) {
      m.s = Eigen::VectorXf::Ones(2);
      m.u = Eigen::MatrixXf::Constant(20, 2, 0.5f);
      m.sxv = Eigen::MatrixXf::Constant(12, 2, 0.25f);
    }
    return f;
  };
  EXPECT_NO_THROW(UboBtf::from_bytes(test::write_ubo_btf(s, factors()), "good.btf"));
  auto f = factors();
  f[1].u = Eigen::MatrixXf::Constant(19, 2, 0.5f);  // a light missing from the rows
  EXPECT_NE(open_error(test::write_ubo_btf(s, f)).find("channel 1 is 19 x 12 but"),
            std::string::npos);
  f = factors();
  f[2].u(7, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(open_error(test::write_ubo_btf(s, f)).find("channel 2's U holds NaN at row 7"),
            std::string::npos);
  f = factors();
  f[0].sxv(9, 0) = std::numeric_limits<float>::infinity();  // pixel x=1, y=2
  const UboBtf b = UboBtf::from_bytes(test::write_ubo_btf(s, f), "sxv.btf");
  EXPECT_NO_THROW(
      b.load_tile({.x = 0, .y = 0, .width = 4, .height = 2}));  // the tile does not hold that pixel
  EXPECT_NE(test::error_of([&] {
              b.load_tile({.x = 0, .y = 1, .width = 2, .height = 2});
            }).find("an infinity at pixel x=1 y=2"),
            std::string::npos);
}

// ---- the command -------------------------------------------------------------------------

#ifdef BTFGMM_CLI_PATH
TEST(UboBtfCli, ConvertReproducesTheImagesInfoListsTheDirectionsAndAFitRuns) {
  UboSpec s = small_spec(true, 16, 16);
  s.colour_model = 11;
  const std::vector<float> images = known_images(s);
  const fs::path dir = fs::temp_directory_path() / "btfgmm_ubo_cli";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path file = dir / "material.btf";
  const auto bytes = test::write_ubo_btf_images(s, images);
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));

  auto r = test::run_cli(
      "convert " + file.string() + " --tile 2,3,5,4 -q -o " + (dir / "exr").string(), "ubo");
  ASSERT_EQ(r.status, 0) << r.err;
  const BtfSource converted = BtfSource::open(dir / "exr");
  EXPECT_EQ(converted.info().lights.size(), 5u);
  const Btf back = converted.load();
  const BtfSource original = BtfSource::open(file);
  for (std::size_t l = 0; l < 5; ++l)
    for (std::size_t v = 0; v < 4; ++v) {
      const std::size_t lb = *back.lights().find(original.info().lights[l], 0.06);
      const std::size_t vb = *back.views().find(original.info().views[v], 0.06);
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 5; ++x)
          for (int c = 0; c < 3; ++c) {
            const float want =
                images[((l * 4 + v) * 256 + std::size_t(y + 3) * 16 + (x + 2)) * 3 + c];
            ASSERT_NEAR(back.at(lb, vb, x, y, c), want, 0.02 * want);
          }
    }
  // What it will write, said before it starts (pixels before compression: 3 bytes each in PNG)
  const ConvertPlan exr_plan = plan_conversion(original, {2, 3, 5, 4}, dir / "exr", {});
  EXPECT_EQ(exr_plan.images, 20u);
  EXPECT_EQ(exr_plan.format, ImageFormat::kExr);
  EXPECT_EQ(exr_plan.pixel_bytes, 20u * 5 * 4 * 12);
  r = test::run_cli(
      "convert " + file.string() + " --format png --exposure 0.5 -o " + (dir / "png").string(),
      "ubo");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("convert: 20 PNG images of 16x16 pixels to " + (dir / "png").string() +
                       ", 15.0 KiB of pixels before compression"),
            std::string::npos)
      << r.err;
  const Btf png = BtfSource::open(dir / "png").load();
  EXPECT_EQ(png.format(), SampleFormat::kLdr8);
  EXPECT_EQ(png.width(), 16);
  // levels = round(255 x 0.5 x value): light 0 (at the pole) and view 0 keep their order
  for (std::size_t q = 0; q < 256; ++q)
    ASSERT_NEAR(png.data()[q * 3], 127.5 * images[q * 3], 0.5 + 0.02 * 127.5 * images[q * 3]);

  r = test::run_cli("info --json " + file.string(), "ubo");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["lights"], 5);
  EXPECT_EQ(j["views"], 4);
  EXPECT_NEAR(double(j["light_directions"][3][1]), 270.0, 1e-3);
  EXPECT_NE(std::string(j["details"]["colour model"]).find("11"), std::string::npos);

  r = test::run_cli("fit " + file.string() + " --tile 0,0,16,16 -M 4 --iterations 2 -q -o " +
                        (dir / "m.btfgmm").string(),
                    "ubo");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "m.btfgmm"));
  fs::remove_all(dir);
}
#endif

// A .btf file's images are decoded one at a time for the seamless-tile search and the cut: the
// made tile's pixels past the overlaps are the file's own.
TEST(UboBtf, ASeamlessTileIsSearchedAndCutFromAFile) {
  const UboSpec s = small_spec(true, 14, 12);
  const fs::path p = write_file(test::write_ubo_btf_images(s, known_images(s)), "cut.btf");
  const BtfSource src = BtfSource::open(p);
  TileSearchConfig search;
  search.min_width = search.max_width = 8;
  search.min_height = search.max_height = 6;
  const TileSearchResult crop = find_seamless_tile(src, search);
  EXPECT_EQ(crop.tile.width, 8);
  EXPECT_EQ(crop.images, 20u);
  SeamlessTileConfig c;
  c.width = 8;
  c.height = 6;
  const SeamlessTile t = cut_seamless_tile(src, c);
  EXPECT_EQ(t.images, 20u);
  const Btf made = seamless_tile_source(src, t).load();
  const Btf whole = src.load();
  for (std::size_t l = 0; l < 5; ++l)
    for (int y = t.overlap_y; y < 6; ++y)
      for (int x = t.overlap_x; x < 8; ++x)
        EXPECT_EQ(made.at(l, 1, x, y, 0), whole.at(l, 1, t.region.x + x, t.region.y + y, 0));
  fs::remove(p);
}

}  // namespace
}  // namespace btfgmm
