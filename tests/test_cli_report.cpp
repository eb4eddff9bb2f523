// The report of `btfgmm compare --report`: the models of one tile side by side at the same
// (light, view) pairs, with compare's per-image PSNR, and a synthesis model marked as such.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/methods/registry.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

test::CliRun run(const std::string& args) {
  return test::run_cli(args, "report_test");
}

// The caption of the figure whose picture is `png`: from the picture to the figure's end.
std::string caption_of(const std::string& html, const std::string& png) {
  const std::size_t at = html.find("src=\"" + png + "\"");
  if (at == std::string::npos) return "";
  return html.substr(at, html.find("</figure>", at) - at);
}

TEST(ReportCli, ShowsTheModelsOfATileSideBySide) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_sbs_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d = dir.string();
  test::CliRun r =
      run("generate --material knit --size 12 --seed 4 --lights rings:0/1,30/4,60/6 "
          "--views rings:0/1,45/5 -o " +
          d + "/btf");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("fit " + d + "/btf -M 6 --iterations 2 -q -o " + d + "/a.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("fit " + d + "/btf --method pca-btf --components 3 -q -o " + d + "/b.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("fit " + d + "/btf --method 3d-car --clusters 3 -q -o " + d + "/c.btfgmm");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("compare " + d + "/btf " + d + "/a.btfgmm " + d + "/b.btfgmm " + d +
          "/c.btfgmm -q --report " + d + "/report");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string html = slurp(dir / "report/index.html");
  ASSERT_NE(html.find("The models side by side"), std::string::npos);

  // compare's per-image PSNR of each model, from the library on the same tile.
  const Btf tile = BtfSource::open(d + "/btf").load({.x = 0, .y = 0, .width = 12, .height = 12});
  std::vector<ModelComparison> cs;
  for (const char* m : {"a", "b", "c"}) {
    const std::string path = d + "/" + m + ".btfgmm";
    cs.push_back(compare_model(tile, load_representation(path), path, fs::file_size(path)));
  }
  // Rows: a's two worst images by PSNR, then its median.
  const std::vector<std::size_t> order = cs[0].quality.by_psnr();
  const std::size_t rows[] = {order[0], order[1], order[order.size() / 2]};
  const std::size_t nv = tile.views().size();
  for (std::size_t row = 0; row < 3; ++row) {
    const std::string original = fmt::format("sbs_r{}_original.png", row + 1);
    EXPECT_TRUE(fs::exists(dir / "report" / original)) << original;
    const Direction& l = tile.lights()[rows[row] / nv];
    const Direction& v = tile.views()[rows[row] % nv];
    EXPECT_NE(caption_of(html, original)
                  .find(fmt::format("light &theta; {:g}&deg; &phi; {:g}&deg;<br>view &theta; "
                                    "{:g}&deg; &phi; {:g}&deg;",
                                    l.theta_deg, l.phi_deg, v.theta_deg, v.phi_deg)),
              std::string::npos)
        << caption_of(html, original);
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string png = fmt::format("sbs_r{}_m{}.png", row + 1, k + 1);
      EXPECT_TRUE(fs::exists(dir / "report" / png)) << png;
      EXPECT_EQ(read_image_header(dir / "report" / png).width, 12 * 11);  // as the original
      const std::string caption = caption_of(html, png);
      EXPECT_NE(caption.find(fmt::format("<b>{}</b>", "abc"[k])), std::string::npos) << caption;
      EXPECT_NE(caption.find(fmt::format("file {} bytes", cs[k].file_bytes)), std::string::npos)
          << caption;
      // The mixture's objective, as its provenance records it (the default fit's).
      EXPECT_EQ(caption.find("objective prediction") != std::string::npos, k == 0) << caption;
      if (k < 2) {
        const double psnr = cs[k].quality.images[rows[row]].psnr_db;
        EXPECT_NE(caption.find(fmt::format("PSNR {:.2f} dB", psnr)), std::string::npos) << caption;
      } else {
        EXPECT_NE(caption.find("synthesis of new texture"), std::string::npos) << caption;
        EXPECT_NE(caption.find("seed 1"), std::string::npos) << caption;
        EXPECT_EQ(caption.find("PSNR "), std::string::npos) << caption;
      }
    }
  }
  // The synthesis at twice the tile beside the data tiled 2 x 2.
  for (const char* png : {"sbs_texture_data.png", "sbs_texture_m3.png"}) {
    ASSERT_TRUE(fs::exists(dir / "report" / png)) << png;
    EXPECT_EQ(read_image_header(dir / "report" / png).width, 2 * 12 * 11) << png;
    EXPECT_NE(html.find(png), std::string::npos) << png;
  }
  EXPECT_FALSE(fs::exists(dir / "report/sbs_texture_m1.png"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
