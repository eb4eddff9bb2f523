// Quality metrics (RMSE, PSNR, SSIM), the paper's compression ratio, the comparison of a model
// with its tile, the report's pictures and curves, and `btfgmm compare` end to end.
// SSIM against scikit-image is checked separately (tests/ssim_check.py).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/report/report.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// A deterministic pseudo-random image in 0..255 (whole levels when `levels`).
std::vector<float> noise_image(int w, int h, std::uint32_t seed, bool levels = true) {
  std::vector<float> v(std::size_t(w) * std::size_t(h) * 3);
  std::uint32_t s = seed * 2654435761u + 1u;
  for (float& x : v) {
    s = s * 1664525u + 1013904223u;
    const double u = double(s >> 8) / double(1u << 24);
    x = levels ? float(std::floor(u * 256.0)) : float(u * 255.0);
  }
  return v;
}

// The values of every ` name="..."` attribute in a text.
std::vector<std::string> attribute_values(const std::string& text, const std::string& name) {
  std::vector<std::string> out;
  const std::string key = " " + name + "=\"";
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    const std::size_t begin = at + key.size(), end = text.find('"', begin);
    if (end == std::string::npos) break;
    out.push_back(text.substr(begin, end - begin));
  }
  return out;
}

const double kPsnrOfOneLevel = 20.0 * std::log10(255.0);  // 48.1308 dB

TEST(Metrics, IdenticalImagesHaveNoErrorAndSsimOne) {
  const auto a = noise_image(16, 13, 1);
  const ImageQuality q = image_quality(a, a, 16, 13, 255.0);
  EXPECT_EQ(q.rmse, 0.0);
  EXPECT_TRUE(std::isinf(q.psnr_db) && q.psnr_db > 0);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(q.rmse_rgb[std::size_t(c)], 0.0);
    EXPECT_NEAR(q.ssim_rgb[std::size_t(c)], 1.0, 1e-12);
  }
  EXPECT_NEAR(q.ssim, 1.0, 1e-12);
}

TEST(Metrics, AnOffsetOfOneLevelIsRmseOneAndPsnr48_13) {
  auto a = noise_image(16, 16, 2);
  for (float& v : a) v = std::min(v, 254.0f);
  auto b = a;
  for (float& v : b) v += 1.0f;
  std::vector<float> err;
  const ImageQuality q = image_quality(a, b, 16, 16, 255.0, {}, &err);
  EXPECT_DOUBLE_EQ(q.rmse, 1.0);
  EXPECT_NEAR(q.psnr_db, 48.13, 0.005);
  EXPECT_DOUBLE_EQ(q.psnr_db, kPsnrOfOneLevel);
  for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(q.psnr_db_rgb[std::size_t(c)], kPsnrOfOneLevel);
  ASSERT_EQ(err.size(), a.size());
  for (float e : err) ASSERT_EQ(e, 1.0f);

  // Offsets 1, 2, 3 in R, G, B: RMSE per channel 1, 2, 3; overall sqrt((1 + 4 + 9) / 3).
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = a[i] + float(i % 3 + 1);
  const ImageQuality r = image_quality(a, b, 16, 16, 255.0);
  EXPECT_DOUBLE_EQ(r.rmse_rgb[0], 1.0);
  EXPECT_DOUBLE_EQ(r.rmse_rgb[1], 2.0);
  EXPECT_DOUBLE_EQ(r.rmse_rgb[2], 3.0);
  EXPECT_NEAR(r.rmse, std::sqrt(14.0 / 3.0), 1e-12);
  EXPECT_NEAR(r.psnr_db_rgb[1], 20.0 * std::log10(255.0 / 2.0), 1e-12);
}

TEST(Metrics, SsimOfFlatImagesIsTheLuminanceTerm) {
  // Flat images: no variance, so SSIM = (2 a b + C1) / (a^2 + b^2 + C1), C1 = (0.01 * 255)^2.
  const double c1 = (0.01 * 255.0) * (0.01 * 255.0);
  const double expected = (2.0 * 100 * 110 + c1) / (100.0 * 100 + 110.0 * 110 + c1);
  for (const auto& [w, h] : {std::pair{16, 12}, std::pair{5, 7}, std::pair{1, 1}}) {
    const std::vector<float> a(std::size_t(w * h * 3), 100.0f), b(a.size(), 110.0f);
    std::vector<double> map;
    // 1e-12: the window sums' rounding depends on the optimisation level (3e-14 at the -O1 of
    // the sanitizer build).
    EXPECT_NEAR(ssim_channel(a, b, w, h, 1, 255.0, {}, &map), expected, 1e-12) << w << "x" << h;
    const int r = ssim_radius(w, h);
    EXPECT_EQ(map.size(), std::size_t((w - 2 * r) * (h - 2 * r)));
  }
  EXPECT_EQ(ssim_radius(16, 12), 5);  // 11 x 11
  EXPECT_EQ(ssim_radius(10, 40), 4);  // 9 x 9: the largest odd window in 10 pixels
  EXPECT_EQ(ssim_radius(5, 7), 2);
  EXPECT_EQ(ssim_radius(1, 1), 0);
}

// SSIM at every window centre, straight from the definition with a 2-D Gaussian window
// (no separable passes, no shared sums), against the map the library returns.
TEST(Metrics, SsimMapMatchesTheDefinitionAtEveryWindow) {
  for (const auto& [w, h] : {std::pair{14, 12}, std::pair{7, 9}}) {
    const auto a = noise_image(w, h, 3, false);
    auto b = a;
    for (std::size_t i = 0; i < b.size(); ++i) b[i] = 0.7f * a[i] + 0.3f * float((i * 37) % 251);
    const int r = ssim_radius(w, h);
    std::vector<double> map;
    const double mean = ssim_channel(a, b, w, h, 2, 255.0, {}, &map);
    const double c1 = std::pow(0.01 * 255, 2), c2 = std::pow(0.03 * 255, 2);
    double wsum = 0.0;
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) wsum += std::exp(-(dx * dx + dy * dy) / (2 * 1.5 * 1.5));
    double total = 0.0;
    for (int cy = r; cy < h - r; ++cy)
      for (int cx = r; cx < w - r; ++cx) {
        double ux = 0, uy = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            const double g = std::exp(-(dx * dx + dy * dy) / (2 * 1.5 * 1.5)) / wsum;
            const std::size_t i =
                (std::size_t(cy + dy) * std::size_t(w) + std::size_t(cx + dx)) * 3 + 2;
            ux += g * a[i];
            uy += g * b[i];
          }
        double vx = 0, vy = 0, vxy = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            const double g = std::exp(-(dx * dx + dy * dy) / (2 * 1.5 * 1.5)) / wsum;
            const std::size_t i =
                (std::size_t(cy + dy) * std::size_t(w) + std::size_t(cx + dx)) * 3 + 2;
            vx += g * (a[i] - ux) * (a[i] - ux);
            vy += g * (b[i] - uy) * (b[i] - uy);
            vxy += g * (a[i] - ux) * (b[i] - uy);
          }
        const double s =
            (2 * ux * uy + c1) * (2 * vxy + c2) / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
        EXPECT_NEAR(map[std::size_t(cy - r) * std::size_t(w - 2 * r) + std::size_t(cx - r)], s,
                    1e-10);
        total += s;
      }
    EXPECT_NEAR(mean, total / double(map.size()), 1e-10);
    EXPECT_LT(mean, 0.99);
    // Symmetric in its two images.
    EXPECT_NEAR(ssim_channel(b, a, w, h, 2, 255.0), mean, 1e-12);
  }
}

TEST(Metrics, BadInputsAreErrors) {
  const auto a = noise_image(4, 4, 1);
  const std::vector<float> short_image(a.size() - 3);
  EXPECT_THROW(image_quality(a, short_image, 4, 4, 255.0), Error);
  EXPECT_THROW(image_quality(a, a, 4, 4, 0.0), Error);
  EXPECT_THROW(ssim_channel(a, a, 4, 4, 3, 255.0), Error);
  EXPECT_THROW(paper_compression_ratio(100, 0, 81, 600), Error);
}

TEST(Metrics, CompressionRatioOfThePapersTable2) {
  // Knitted wool, 25 x 25 pixels, 81 x 81 directions, M = 600: 12,301,875 bytes of data
  // against 43,200 + 19,683 bytes of model.
  const double r = paper_compression_ratio(25 * 25, 81, 81, 600);
  EXPECT_DOUBLE_EQ(r, 12301875.0 / (43200.0 + 19683.0));
  EXPECT_NEAR(r, 195.6, 0.05);
  // The model's own figure is the same formula.
  BtfModel m;
  m.lights = m.views = DirectionSet::ubo81();
  m.width = m.height = 25;
  m.mixture.resize(600);
  EXPECT_DOUBLE_EQ(m.compression_ratio_paper(), r);
  // Linear in the pixel count (the paper's Fig. 4).
  EXPECT_NEAR(paper_compression_ratio(2 * 625, 81, 81, 600), 2 * r, 1e-9);
  EXPECT_NEAR(
      paper_compression_ratio(36 * 46, 81, 81, 600) / paper_compression_ratio(625, 81, 81, 600),
      36.0 * 46.0 / 625.0, 1e-12);
}

const char* kLights = "rings:0/1,30/4,60/6";
const char* kViews = "rings:0/1,45/5";

Btf small_btf(int size, std::uint64_t seed, bool hdr = false) {
  GenerateConfig g;
  g.material = "knit";
  g.size = size;
  g.seed = seed;
  g.lights = DirectionSet::parse(kLights);
  g.views = DirectionSet::parse(kViews);
  g.hdr = hdr;
  g.supersample = 1;
  return generate(g);
}

TEST(Metrics, MeasureQualityAggregatesOverImages) {
  const Btf a = small_btf(12, 1);
  Btf b = a;
  // Image i is off by (i % 4) levels in every value: exact per-image RMSE.
  for (std::size_t i = 0; i < a.image_count(); ++i)
    for (std::size_t k = 0; k < a.image_floats(); ++k)
      b.data()[i * a.image_floats() + k] += float(i % 4);
  const BtfQuality q = measure_quality(a, b);
  ASSERT_EQ(q.images.size(), a.image_count());
  EXPECT_EQ(q.range, 255.0);
  EXPECT_EQ(q.ssim_window, 11);
  double mse = 0;
  for (std::size_t i = 0; i < a.image_count(); ++i) {
    EXPECT_NEAR(q.images[i].rmse, double(i % 4), 1e-6);
    mse += double((i % 4) * (i % 4)) / double(a.image_count());
  }
  EXPECT_NEAR(q.rmse, std::sqrt(mse), 1e-6);
  EXPECT_NEAR(q.psnr_db, 20 * std::log10(255 / std::sqrt(mse)), 1e-6);
  EXPECT_EQ(q.worst_psnr, 3u);  // the first image off by 3
  EXPECT_EQ(q.best_psnr, 0u);   // exact
  const auto order = q.by_psnr();
  for (std::size_t k = 1; k < order.size(); ++k)
    EXPECT_LE(q.images[order[k - 1]].psnr_db, q.images[order[k]].psnr_db);
  double ssim = 0;
  for (const auto& iq : q.images) ssim += iq.ssim / double(q.images.size());
  EXPECT_NEAR(q.ssim, ssim, 1e-12);
  EXPECT_NEAR(q.images[0].ssim, 1.0, 1e-12);
  EXPECT_LT(q.images[3].ssim, 1.0);

  // Other direction sets or sizes are refused.
  const Btf other(DirectionSet::parse("rings:0/1,30/4"), a.views(), 12, 12, a.format());
  EXPECT_THROW(measure_quality(a, other), Error);
  const Btf smaller(a.lights(), a.views(), 10, 12, a.format());
  EXPECT_THROW(measure_quality(a, smaller), Error);
}

TEST(Metrics, HdrRangeIsTheOriginalsPeak) {
  const Btf a = small_btf(8, 2, true);
  ASSERT_EQ(a.format(), SampleFormat::kHdr);
  float peak = 0;
  for (float v : a.data()) peak = std::max(peak, v);
  EXPECT_EQ(data_range(a), double(peak));
  Btf b = a;
  for (float& v : b.data()) v += 0.01f * peak;
  const BtfQuality q = measure_quality(a, b);
  EXPECT_EQ(q.range, double(peak));
  EXPECT_NEAR(q.psnr_db, 40.0, 1e-3);  // an offset of 1 % of the range
  EXPECT_EQ(q.ssim_window, 7);         // 8 pixels: the window shrinks to 7 x 7
}

// ---- the comparison and the report ------------------------------------------------------

BtfModel small_fit(const Btf& btf, std::size_t m, int iterations) {
  FitConfig c;
  c.components = m;
  c.seed = 3;
  c.em.max_iterations = iterations;
  return fit_model(btf, c);
}

TEST(Report, CompareModelMeasuresTheDecodedTileAndPicksPairs) {
  const Btf btf = small_btf(12, 4);
  const BtfModel model = small_fit(btf, 8, 3);
  const ModelComparison c = compare_model(btf, model, "m.btfgmm", 1234);
  const BtfQuality direct = measure_quality(btf, decode(model, model.lights, model.views, 12, 12));
  EXPECT_DOUBLE_EQ(c.quality.rmse, direct.rmse);
  EXPECT_DOUBLE_EQ(c.quality.ssim, direct.ssim);
  EXPECT_GT(c.quality.rmse, 0.0);
  // The mean BRDF alone: every pixel its image's mean.
  EXPECT_GT(c.mean_brdf_only.rmse, 0.0);
  EXPECT_EQ(c.mean_brdf, mean_brdf(btf));
  // Pictured: frontal light and view first, grazing light (60 deg), grazing view (45 deg),
  // then the three worst by PSNR.
  ASSERT_GE(c.pairs.size(), 3u);
  EXPECT_EQ(c.pairs[0].light, 0u);
  EXPECT_EQ(c.pairs[0].view, 0u);
  EXPECT_EQ(btf.lights()[c.pairs[1].light].theta_deg, 60.0);
  EXPECT_EQ(btf.views()[c.pairs[2].view].theta_deg, 45.0);
  const std::size_t worst = c.quality.by_psnr()[0];
  bool found = false;
  for (const auto& p : c.pairs)
    if (p.light * btf.views().size() + p.view == worst) {
      found = true;
      EXPECT_NE(p.label.find("worst PSNR 1"), std::string::npos) << p.label;
      EXPECT_EQ(p.original, std::vector<float>(btf.image(p.light, p.view),
                                               btf.image(p.light, p.view) + btf.image_floats()));
    }
  EXPECT_TRUE(found);
  // Another BTF's direction sets: an error naming the model.
  const Btf other = [] {
    GenerateConfig g;
    g.size = 12;
    g.lights = DirectionSet::parse("rings:0/1,30/4");
    g.views = DirectionSet::parse(kViews);
    g.supersample = 1;
    return generate(g);
  }();
  try {
    compare_model(other, model, "m.btfgmm", 0);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.btfgmm"), std::string::npos) << e.what();
  }
}

TEST(Report, PicturesFollowThePapersLayout) {
  // Mean BRDF: rows = lights, columns = views, brightest value 255.
  const std::size_t ni = 3, nv = 2;
  std::vector<float> mean(ni * nv * 3);
  for (std::size_t i = 0; i < mean.size(); ++i) mean[i] = float(i);
  const Image img = mean_brdf_image(mean, ni, nv, SampleFormat::kLdr8);
  EXPECT_EQ(img.width, 2);
  EXPECT_EQ(img.height, 3);
  const float peak = float(mean.size() - 1);
  // pixel (x = view 1, y = light 2), green
  EXPECT_NEAR(img.rgb[(2 * 2 + 1) * 3 + 1], 255.0f * float((2 * nv + 1) * 3 + 1) / peak, 1e-3);

  const Image up = upscale_nearest(img, 4);
  EXPECT_EQ(up.width, 8);
  EXPECT_EQ(up.height, 12);
  EXPECT_EQ(up.rgb[(11 * 8 + 7) * 3], img.rgb[(2 * 2 + 1) * 3]);
  EXPECT_EQ(up.rgb[(3 * 8 + 3) * 3 + 2], img.rgb[2]);

  // 10 x |difference|, clamped to 255.
  const std::vector<float> a{10, 20, 30}, b{12, 20, 0};
  const Image d = difference_image(a, b, 1, 1, SampleFormat::kLdr8, 255.0);
  EXPECT_EQ(d.rgb, (std::vector<float>{20, 0, 255}));

  // PSNR map: the worst image at the low end of the colour map, exact images at the top.
  BtfQuality q;
  q.lights = 2;
  q.views = 2;
  q.images.resize(4);
  q.images[0].psnr_db = 30;
  q.images[1].psnr_db = 20.4;
  q.images[2].psnr_db = 25;
  q.images[3].psnr_db = std::numeric_limits<double>::infinity();
  const auto range = psnr_map_range(q);
  EXPECT_EQ(range[0], 20.0);
  EXPECT_EQ(range[1], 30.0);
  const Image map = psnr_map_image(q, range[0], range[1]);
  EXPECT_EQ(map.width, 2);
  EXPECT_EQ(map.height, 2);
  const auto lo = colour_map(0.04), hi = colour_map(1.0), mid = colour_map(0.5);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(map.rgb[3 + k], lo[k], 1e-4);
    EXPECT_NEAR(map.rgb[6 + k], mid[k], 1e-4);
    EXPECT_EQ(map.rgb[9 + k], hi[k]);
  }
  // viridis runs from dark purple to yellow.
  EXPECT_LT(colour_map(0.0)[1], 10.0f);
  EXPECT_GT(colour_map(1.0)[0], 250.0f);
}

TEST(Report, ChartsPlotEveryPointInsideTheAxes) {
  Chart c;
  c.title = "t <1>";
  c.x_label = "x";
  c.y_label = "y";
  c.x_from_zero = true;
  ChartSeries s;
  s.label = "series";
  s.markers = true;
  s.points = {{10, 21.5}, {50, 25}, {150, 27.25}, {300, 28}};
  c.series = {s};
  const std::string svg = svg_chart(c);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("t &lt;1&gt;"), std::string::npos);  // escaped
  std::size_t circles = 0;
  for (std::size_t at = svg.find("<circle"); at != std::string::npos;
       at = svg.find("<circle", at + 1))
    ++circles;
  EXPECT_EQ(circles, 5u);  // four points and the legend's marker
  const auto polylines = attribute_values(svg, "points");
  ASSERT_EQ(polylines.size(), 1u);
  std::istringstream pts(polylines[0]);
  std::string xy;
  int n = 0;
  double last_x = -1, last_y = 1e9;
  while (pts >> xy) {
    const double x = std::stod(xy.substr(0, xy.find(','))),
                 y = std::stod(xy.substr(xy.find(',') + 1));
    EXPECT_GE(x, 62.0);
    EXPECT_LE(x, c.width - 14.0);
    EXPECT_GE(y, 30.0);
    EXPECT_LE(y, c.height - 44.0);
    EXPECT_GT(x, last_x);  // x grows to the right
    EXPECT_LT(y, last_y);  // larger y is higher up
    last_x = x;
    last_y = y;
    ++n;
  }
  EXPECT_EQ(n, 4);
}

TEST(Report, CompressionRatioChartIsLinearThroughTheModels) {
  const Btf btf = small_btf(12, 5);
  std::vector<ModelComparison> cs{compare_model(btf, small_fit(btf, 4, 1), "a", 5000),
                                  compare_model(btf, small_fit(btf, 9, 1), "b", 9000)};
  const Chart c = compression_ratio_chart(cs);
  // Lines for M = 4, M = 9 and the paper's M = 600, then the models as points.
  ASSERT_GE(c.series.size(), 5u);
  std::size_t lines = 0;
  for (const auto& s : c.series)
    if (s.line) {
      ++lines;
      ASSERT_EQ(s.points.size(), 2u);
      EXPECT_EQ(s.points[0][1], 0.0);  // through the origin: linear in the pixel count
    }
  EXPECT_EQ(lines, 3u);
  const auto& points = c.series[3].points;  // the paper's count
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0][0], 144.0);
  EXPECT_DOUBLE_EQ(points[0][1], cs[0].model->paper_ratio());
  // Each model's point lies on the line of its M.
  const auto& line4 = c.series[0];
  EXPECT_NEAR(line4.points[1][1] / line4.points[1][0] * 144.0, points[0][1], 1e-9);
  EXPECT_DOUBLE_EQ(c.series[4].points[1][1], cs[1].model->file_ratio(9000));
}

TEST(Report, WritesASelfContainedReport) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_report_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const Btf btf = small_btf(12, 6);
  std::vector<ModelComparison> cs{compare_model(btf, small_fit(btf, 5, 2), "five.btfgmm", 4000),
                                  compare_model(btf, small_fit(btf, 10, 2), "ten.btfgmm", 8000)};
  write_report(dir, "knit12/", cs);
  std::ifstream in(dir / "index.html");
  const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(html.empty());
  // No network: nothing is fetched from anywhere but the folder itself.
  EXPECT_EQ(html.find("http:"), std::string::npos);
  EXPECT_EQ(html.find("https:"), std::string::npos);
  EXPECT_EQ(html.find("src=\"/"), std::string::npos);
  // Every picture it names is there, and is a PNG of the size the page says.
  std::vector<std::string> refs = attribute_values(html, "src");
  for (const auto& h : attribute_values(html, "href")) refs.push_back(h);
  int pictures = 0;
  for (const std::string& name : refs) {
    const fs::path p = dir / name;
    EXPECT_TRUE(fs::exists(p)) << p;
    if (fs::exists(p)) {
      EXPECT_NO_THROW(read_image_header(p)) << p;
    }
    ++pictures;
  }
  // Per model at least 3 pairs x 3 pictures and the PSNR map; one mean BRDF (one tile).
  EXPECT_GE(pictures, 2 * (9 + 1) + 1);
  const ImageHeader brdf = read_image_header(dir / "m1_mean_brdf.png");
  EXPECT_EQ(brdf.height * 6, brdf.width * 11);  // 11 lights (rows) x 6 views (columns)
  EXPECT_FALSE(fs::exists(dir / "m2_mean_brdf.png"));
  const ImageHeader pic = read_image_header(dir / "m1_l0_v0_original.png");
  EXPECT_EQ(pic.width, 12 * 11);  // a 12-pixel tile enlarged 11 x (>= 128 pixels)
  // The numbers, the curves, the names.
  EXPECT_NE(html.find(fmt::format("{:.2f}", cs[1].quality.rmse)), std::string::npos);
  EXPECT_NE(html.find(fmt::format("{:.3f}", cs[0].quality.ssim)), std::string::npos);
  EXPECT_NE(html.find("ten.btfgmm"), std::string::npos);
  EXPECT_NE(html.find("Compression ratio against tile size"), std::string::npos);
  EXPECT_NE(html.find("rate-distortion"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
  fs::remove_all(dir);
}

// ---- btfgmm compare ------------------------------------------------------------------------

using test::CliRun;

CliRun run(const std::string& args) {
  return test::run_cli(args, "compare_test");
}

TEST(CompareCli, TableJsonAndReportOfTheModelsTile) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_compare_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d = dir.string();
  const std::string sets = std::string(" --lights ") + kLights + " --views " + kViews;
  CliRun r = run("generate --material bumps --size 16 --seed 4" + sets + " -o " + d + "/btf");
  ASSERT_EQ(r.status, 0) << r.err;
  // A tile away from the origin: compare must read exactly that tile.
  r = run("fit " + d + "/btf --tile 3,2,12,11 -M 6 --iterations 2 -q -o " + d + "/a.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("fit " + d + "/btf --tile 3,2,12,11 -M 12 --iterations 2 -q -o " + d + "/b.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;

  r = run("compare " + d + "/btf " + d + "/a.btfgmm --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"rmse", "psnr_db", "ssim", "compression_ratio_paper",
                          "compression_ratio_file", "components", "tile"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["tile"], nlohmann::json({3, 2, 12, 11}));
  EXPECT_EQ(j["components"], 6);
  EXPECT_EQ(j["file_bytes"], fs::file_size(d + "/a.btfgmm"));
  // The same numbers from the library on the same tile.
  const BtfModel m = load_model(d + "/a.btfgmm");
  const Btf tile = BtfSource::open(d + "/btf").load({.x = 3, .y = 2, .width = 12, .height = 11});
  const BtfQuality q = measure_quality(tile, decode(m, m.lights, m.views, 12, 11));
  EXPECT_NEAR(j["rmse"].get<double>(), q.rmse, 1e-9);
  EXPECT_NEAR(j["ssim"].get<double>(), q.ssim, 1e-9);
  EXPECT_NEAR(j["psnr_db"].get<double>(), 20 * std::log10(255 / q.rmse), 1e-9);
  EXPECT_NEAR(j["compression_ratio_paper"].get<double>(), m.compression_ratio_paper(), 1e-9);
  EXPECT_NEAR(j["compression_ratio_file"].get<double>(),
              m.compression_ratio_file(fs::file_size(d + "/a.btfgmm")), 1e-9);
  EXPECT_LE(j["worst_psnr"]["psnr_db"].get<double>(), j["best_psnr"]["psnr_db"].get<double>());

  // The table.
  r = run("compare " + d + "/btf " + d + "/a.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* word : {"RMSE", "PSNR", "SSIM", "worst image", "paper's count", "seed 1"})
    EXPECT_NE(r.out.find(word), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(fmt::format("{:.3f}", q.rmse)), std::string::npos) << r.out;

  // Two models, a report.
  r = run("compare " + d + "/btf " + d + "/a.btfgmm " + d + "/b.btfgmm --json --report " + d +
          "/report");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto both = nlohmann::json::parse(r.out);
  ASSERT_TRUE(both.is_array());
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(both[1]["components"], 12);
  EXPECT_TRUE(fs::exists(d + "/report/index.html"));
  EXPECT_TRUE(fs::exists(d + "/report/compare.json"));
  EXPECT_NE(r.err.find("index.html"), std::string::npos) << r.err;
  // A non-empty report folder needs --overwrite.
  r = run("compare " + d + "/btf " + d + "/a.btfgmm --report " + d + "/report");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;

  // A BTF with other directions: a clear error naming both.
  r = run("generate --material bumps --size 16 --lights rings:0/1,30/4 --views " +
          std::string(kViews) + " -o " + d + "/other");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("compare " + d + "/other " + d + "/a.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("a.btfgmm"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("fitted to"), std::string::npos) << r.err;
  // A model that is not there, or not a model.
  r = run("compare " + d + "/btf " + d + "/a.btfgmm " + d + "/nowhere.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("nowhere.btfgmm"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("compared"), std::string::npos) << "checked before any work: " << r.err;
  // A BTF too small for the model's tile.
  r = run("generate --material bumps --size 8" + sets + " -o " + d + "/small");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("compare " + d + "/small " + d + "/a.btfgmm");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("tile"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
