// The exported shader and the viewer (render/shader.hpp, render/viewer.hpp): the parameter
// texture against the model, the parameter file, the commands, and in headless Chromium the
// page's pixels (and those of the exported files) against `btfgmm render` on the CPU.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/lpca.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "btfgmm/methods/pca_btf.hpp"
#include "btfgmm/methods/pca_rf.hpp"
#include "btfgmm/methods/plm_rf.hpp"
#include "btfgmm/methods/ptm_rf.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/render/shader.hpp"
#include "btfgmm/render/viewer.hpp"
#include "test_util.hpp"

#include <unistd.h>

namespace {

using namespace btfgmm;
namespace fs = std::filesystem;

const std::string kGolden = std::string(BTFGMM_TEST_DATA) + "/golden_v2_gm.btfgmm";

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path fresh_dir(const std::string& tag) {
  const fs::path d =
      fs::temp_directory_path() / ("btfgmm_view_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(Shader, MixtureTexelsHoldEachComponentAsGlslReadsIt) {
  const auto model = load_representation(kGolden);
  const BtfModel& m = dynamic_cast<const GaussianMixture&>(*model).model();
  const ShaderExport s = export_shader(*model);
  EXPECT_EQ(s.method, "gm");
  EXPECT_TRUE(s.has_mean_brdf);
  EXPECT_NE(s.glsl.find("vec3 btf(vec2 uv, vec3 light, vec3 view)"), std::string::npos);
  EXPECT_NE(s.glsl.find(fmt::format("const int BTF_M = {};", m.mixture.size())), std::string::npos);
  ASSERT_EQ(s.texels.size(), std::size_t(s.width) * std::size_t(s.height) * 4);
  // The components' table: where the GLSL's constant says, four texels each.
  const std::string key = "const int BTF_COMPONENTS = ";
  const std::size_t at = s.glsl.find(key);
  ASSERT_NE(at, std::string::npos);
  const std::size_t c0 = std::stoul(s.glsl.substr(at + key.size()));
  const std::size_t last = m.mixture.size() - 1;
  const float* t = &s.texels[4 * (c0 + 4 * last)];
  const auto& var = m.mixture.var[last];
  const auto& mu = m.mixture.mean[last];
  double base = std::log(m.mixture.weight[last]);
  for (int n = 0; n < kInputs; ++n) base -= 0.5 * std::log(var[std::size_t(n)]);
  EXPECT_FLOAT_EQ(t[2], float(mu[2]));
  EXPECT_FLOAT_EQ(t[4], float(mu[4]));
  EXPECT_FLOAT_EQ(t[6], float(-0.5 / var[0]));
  EXPECT_FLOAT_EQ(t[11], float(-0.5 / var[5]));
  EXPECT_FLOAT_EQ(t[12], float(mu[6]));
  EXPECT_FLOAT_EQ(t[15], float(base));
  EXPECT_GE(t[0], 0.0f);
  EXPECT_LT(t[0], float(m.width));
  // The mean BRDF's table: light-major, one texel a pair.
  const std::string mb = "const int BTF_MEAN_BRDF = ";
  const std::size_t m0 = std::stoul(s.glsl.substr(s.glsl.find(mb) + mb.size()));
  const std::size_t pair = m.mean_brdf.size() / 3 - 1;
  EXPECT_EQ(s.texels[4 * (m0 + pair) + 1], m.mean_brdf[3 * pair + 1]);
}

TEST(Shader, ParameterFileRoundTripsAndRefusesTruncation) {
  const ShaderExport s = export_shader(*load_representation(kGolden));
  const std::vector<std::uint8_t> file = shader_parameter_file(s);
  ASSERT_EQ(file.size(), 16 + s.texels.size() * 4);
  EXPECT_EQ(std::string(file.begin(), file.begin() + 8), "BTFPARAM");
  const ShaderExport back = read_shader_parameter_file(file, "p.bin");
  EXPECT_EQ(back.width, s.width);
  EXPECT_EQ(back.height, s.height);
  EXPECT_EQ(back.texels, s.texels);
  const std::vector<std::uint8_t> cut(file.begin(), file.end() - 4);
  const std::string e = test::error_of([&] { read_shader_parameter_file(cut, "p.bin"); });
  EXPECT_NE(e.find("'p.bin'"), std::string::npos) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
}

TEST(Shader, EveryMethodHasAGenerator) {
  // The texture models synthesise new texture from a seed (their predict runs a synthesis per
  // subspace): no per-pixel shader; export-shader and view refuse them by name.
  for (const MethodInfo& m : all_methods()) {
    if (m.name == "3d-car" || m.name == "2d-car" || m.name == "gmrf") continue;
    bool found = false;
    for (const ShaderGenerator& g : shader_generators()) found = found || g.method == m.name;
    EXPECT_TRUE(found) << m.name;
  }
  const auto plm = load_representation(std::string(BTFGMM_TEST_DATA) + "/golden_v2_plm-rf.btfgmm");
  const ShaderExport s = export_shader(*plm);
  EXPECT_EQ(s.method, "plm-rf");
  EXPECT_NE(s.glsl.find("const float BTF_PLM_SCALE = "), std::string::npos);
  EXPECT_FALSE(s.has_mean_brdf);
}

TEST(Shader, ViewerFilesAreSelfContained) {
  const auto model = load_representation(kGolden);
  const auto files = viewer_files({{"golden", model.get()}});
  ASSERT_EQ(files.size(), 4u);
  EXPECT_EQ(files[0].name, "index.html");
  for (const char* script : {"meshes.js", "models.js", "viewer.js"})
    EXPECT_NE(files[0].text.find(fmt::format("<script src=\"{}\">", script)), std::string::npos);
  // Nothing from the network.
  for (const auto& f : files) EXPECT_EQ(f.text.find("http"), std::string::npos) << f.name;
  EXPECT_NE(files[2].text.find("name: \"cloth\""), std::string::npos);
  EXPECT_NE(files[3].text.find("vec3 btf(vec2 uv, vec3 light, vec3 view)"), std::string::npos);
  EXPECT_EQ(base64("Man", 3), "TWFu");
  EXPECT_EQ(base64("Ma", 2), "TWE=");
}

#ifdef BTFGMM_CLI_PATH
TEST(CliView, ExportShaderWritesTheShaderAndItsParameters) {
  const fs::path d = fresh_dir("export");
  const auto r = test::run_cli(
      fmt::format("export-shader {} --glsl -o {}/m.glsl", kGolden, d.string()), "export");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(slurp(d / "m.glsl").find("vec3 btf(vec2 uv"), std::string::npos);
  const auto bytes = read_whole_file(d / "m.bin", "parameters");
  EXPECT_EQ(read_shader_parameter_file(bytes, "m.bin").texels,
            export_shader(*load_representation(kGolden)).texels);
  const auto again =
      test::run_cli(fmt::format("export-shader {} -o {}/m.glsl", kGolden, d.string()), "export2");
  EXPECT_EQ(again.status, 1);
  EXPECT_NE(again.err.find("--overwrite"), std::string::npos) << again.err;
  fs::remove_all(d);
}

TEST(CliView, ViewWritesThePageAndRefusesAFullFolder) {
  const fs::path d = fresh_dir("page");
  const auto r = test::run_cli(fmt::format("view {} -o {}/page", kGolden, d.string()), "view");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* f : {"index.html", "viewer.js", "meshes.js", "models.js"})
    EXPECT_TRUE(fs::is_regular_file(d / "page" / f)) << f;
  EXPECT_NE(r.err.find("index.html"), std::string::npos);
  const auto again = test::run_cli(fmt::format("view {} -o {}/page", kGolden, d.string()), "view2");
  EXPECT_EQ(again.status, 1);
  EXPECT_NE(again.err.find("not empty"), std::string::npos) << again.err;
  fs::remove_all(d);
}
#endif

// ---- in the browser ------------------------------------------------------------------------

// Debian's chromium on the PATH, or "" (the browser tests are then skipped).
std::string find_browser() {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin";
  for (const char* name : {"chromium", "chromium-browser"}) {
    std::size_t start = 0;
    while (start <= dirs.size()) {
      const std::size_t end = std::min(dirs.find(':', start), dirs.size());
      const fs::path p = fs::path(dirs.substr(start, end - start)) / name;
      if (!p.parent_path().empty() && ::access(p.c_str(), X_OK) == 0) return p.string();
      start = end + 1;
    }
  }
  return "";
}

std::vector<std::uint8_t> unbase64(const std::string& text) {
  std::vector<std::uint8_t> out;
  std::uint32_t acc = 0;
  int bits = 0;
  for (const char c : text) {
    int v = -1;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+')
      v = 62;
    else if (c == '/')
      v = 63;
    if (v < 0) continue;
    acc = acc << 6 | std::uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(std::uint8_t(acc >> bits));
    }
  }
  return out;
}

// The page of `html` in headless Chromium (software WebGL2) with the query `query`: the
// text of its <pre id="readback"> after the page's script ran.
std::string browser_readback(const std::string& browser, const fs::path& html,
                             const std::string& query, const fs::path& work) {
  const fs::path dom = work / "dom.html";
  const std::string cmd = fmt::format(
      "timeout 180 {} --headless=new --no-sandbox --use-angle=swiftshader "
      "--enable-unsafe-swiftshader --no-first-run --disable-extensions "
      "--disable-background-networking --user-data-dir={} --dump-dom 'file://{}?{}' > {} "
      "2> {}",
      browser, (work / "profile").string(), fs::absolute(html).string(), query, dom.string(),
      (work / "browser.log").string());
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd << "\n" << slurp(work / "browser.log");
  const std::string text = slurp(dom);
  // The text of the element `id` (up to the next tag).
  auto element = [&](const std::string& id) -> std::string {
    const std::size_t at = text.find("id=\"" + id + "\"");
    if (at == std::string::npos) return "";
    const std::size_t open = text.find('>', at), close = text.find('<', open);
    return open == std::string::npos || close == std::string::npos
               ? ""
               : text.substr(open + 1, close - open - 1);
  };
  const std::string pixels = element("readback");
  // Without pixels, what the page said (no WebGL2, a shader that did not compile, ...).
  return pixels.empty() ? "error: " + element("error") : pixels;
}

// PSNR in dB of the browser's RGBA pixels ("WxH base64") against a picture's RGB levels.
double psnr_against(const std::string& readback, const Image& cpu) {
  const std::size_t space = readback.find(' ');
  EXPECT_EQ(readback.substr(0, space), fmt::format("{}x{}", cpu.width, cpu.height));
  const std::vector<std::uint8_t> px = unbase64(readback.substr(space + 1));
  const std::size_t n = std::size_t(cpu.width) * std::size_t(cpu.height);
  EXPECT_EQ(px.size(), n * 4);
  if (px.size() != n * 4) return 0.0;
  double se = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < 3; ++c) {
      const double d = double(px[4 * i + c]) - double(cpu.rgb[3 * i + c]);
      se += d * d;
    }
  // Beside the silhouettes and the terminator (a pixel centre on either side of an edge or of
  // l.n = 0 by a rounding), the shading agrees within 2 levels.
  std::size_t off = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double worst = 0.0;
    for (std::size_t c = 0; c < 3; ++c)
      worst = std::max(worst, std::abs(double(px[4 * i + c]) - double(cpu.rgb[3 * i + c])));
    off += worst > 2.0;
  }
  EXPECT_LT(double(off), 0.01 * double(n)) << off << " pixels differ by more than 2 levels";
  const double mse = se / double(3 * n);
  return mse > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
}

#ifdef BTFGMM_CLI_PATH
// The scene of the browser test: the cloth (both sides seen, folds, silhouettes) under a
// light from the side, a small image.
constexpr const char* kScene =
    "--mesh cloth --light 50,30 --camera 55,20 --repeat 2 --size 128x128";
constexpr const char* kQuery =
    "mesh=cloth&light=50,30&camera=55,20&repeat=2&size=128x128&mode=model&readback=1";

TEST(Browser, ViewPageAndExportedShaderMatchTheCpuRender) {
  const std::string browser = find_browser();
  if (browser.empty())
    GTEST_SKIP() << "chromium is not installed (scripts/install-deps installs it)";
  const fs::path d = fresh_dir("browser");
  GenerateConfig g;
  g.material = "knit";
  g.size = 16;
  g.seed = 5;
  g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
  g.views = DirectionSet::parse("rings:0/1,45/5");
  g.supersample = 1;
  FitConfig c;
  c.components = 40;
  c.seed = 3;
  c.em.max_iterations = 4;
  const Btf tile = generate(g);
  const std::string model_path = (d / "knit.btfgmm").string();
  const std::string pca_path = (d / "knit-pca.btfgmm").string();
  save_model(fit_model(tile, c), model_path);
  FitOptions ps;
  ps.components = 6;
  save_representation(*fit_pca_btf(tile, ps), pca_path);
  const std::string pca_rf_path = (d / "knit-pca-rf.btfgmm").string();
  ps.components = 3;
  save_representation(*fit_pca_rf(tile, ps), pca_rf_path);
  const std::string ptm_path = (d / "knit-ptm.btfgmm").string();
  save_representation(*fit_ptm_rf(tile, FitOptions{}), ptm_path);
  const std::string lpca_path = (d / "knit-lpca.btfgmm").string();
  ps.clusters = 3;
  ps.components = 2;
  save_representation(*fit_lpca(tile, ps), lpca_path);
  const std::string plm_path = (d / "knit-plm.btfgmm").string();
  FitOptions pl;
  pl.degree = 2;
  pl.iterations = 5;
  save_representation(*fit_plm_rf(tile, pl), plm_path);
  const std::string neural_path = (d / "knit-neural.btfgmm").string();
  FitOptions nn;
  nn.components = 5;  // two groups of four in the shader, the second padded
  nn.width = 10;
  nn.depth = 2;
  nn.iterations = 3;
  save_representation(*fit_neural_btf(tile, nn), neural_path);

  auto cli = [&](const std::string& args) {
    const auto r = test::run_cli(args, "browser");
    EXPECT_EQ(r.status, 0) << args << "\n" << r.err;
  };
  cli(fmt::format("render {} {} --tolerance 0 -q -o {}/cpu.png", model_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-pca.png", pca_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-pca-rf.png", pca_rf_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-ptm.png", ptm_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-lpca.png", lpca_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-plm.png", plm_path, kScene, d.string()));
  cli(fmt::format("render {} {} -q -o {}/cpu-neural.png", neural_path, kScene, d.string()));
  cli(fmt::format("view {} {} {} {} {} {} {} -q -o {}/page", model_path, pca_path, pca_rf_path,
                  ptm_path, lpca_path, plm_path, neural_path, d.string()));
  cli(fmt::format("export-shader {} --glsl -q -o {}/page/knit.glsl", model_path, d.string()));

  // A second model on the page, read back from export-shader's two files.
  const auto model = load_representation(model_path);
  ShaderExport exported = read_shader_parameter_file(
      read_whole_file(d / "page" / "knit.bin", "parameters"), "knit.bin");
  exported.glsl = slurp(d / "page" / "knit.glsl");
  exported.method = "gm";
  exported.has_mean_brdf = true;
  std::ofstream(d / "page" / "exported.js")
      << viewer_model_script("exported", model->size_text(), model->frame(), exported);
  std::string html = slurp(d / "page" / "index.html");
  const std::string tag = "<script src=\"viewer.js\">";
  ASSERT_NE(html.find(tag), std::string::npos);
  html.replace(html.find(tag), tag.size(), "<script src=\"exported.js\"></script>\n" + tag);
  std::ofstream(d / "page" / "test.html") << html;

  const std::string out = browser_readback(browser, d / "page" / "test.html", kQuery, d);
  ASSERT_FALSE(out.empty()) << slurp(d / "browser.log");
  ASSERT_EQ(out.rfind("error", 0), std::string::npos) << out;
  // The page's models in order: the mixture, PCA BTF, PCA RF, PTM RF, LPCA, PLM RF, the
  // neural BTF, the mixture from the exported files.
  std::vector<std::string> images;
  for (std::size_t start = 0; start < out.size();) {
    const std::size_t end = std::min(out.find('\n', start), out.size());
    images.push_back(out.substr(start, end - start));
    start = end + 1;
  }
  ASSERT_EQ(images.size(), 8u);
  const double psnr = psnr_against(images[0], read_image(d / "cpu.png"));
  const double psnr_pca = psnr_against(images[1], read_image(d / "cpu-pca.png"));
  EXPECT_GE(psnr, 40.0);
  const double psnr_rf = psnr_against(images[2], read_image(d / "cpu-pca-rf.png"));
  EXPECT_GE(psnr_pca, 40.0);
  EXPECT_GE(psnr_rf, 40.0);
  const double psnr_ptm = psnr_against(images[3], read_image(d / "cpu-ptm.png"));
  EXPECT_GE(psnr_ptm, 40.0);
  const double psnr_lpca = psnr_against(images[4], read_image(d / "cpu-lpca.png"));
  EXPECT_GE(psnr_lpca, 40.0);
  const double psnr_plm = psnr_against(images[5], read_image(d / "cpu-plm.png"));
  EXPECT_GE(psnr_plm, 40.0);
  const double psnr_neural = psnr_against(images[6], read_image(d / "cpu-neural.png"));
  EXPECT_GE(psnr_neural, 40.0);
  EXPECT_EQ(images[7], images[0]) << "the exported files render other pixels than the page";
  std::printf(
      "browser against CPU: PSNR %.2f dB (gm), %.2f dB (pca-btf), %.2f dB (pca-rf), %.2f dB "
      "(ptm-rf), %.2f dB (lpca), %.2f dB (plm-rf), %.2f dB (neural)\n",
      psnr, psnr_pca, psnr_rf, psnr_ptm, psnr_lpca, psnr_plm, psnr_neural);
  if (!HasFailure()) fs::remove_all(d);
}
#endif

}  // namespace
