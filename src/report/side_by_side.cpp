// The models of one tile side by side at the same (light, view) pairs; see sections.hpp.
#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "btfgmm/model/decode.hpp"
#include "btfgmm/report/pictures.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace btfgmm::report {

namespace {

namespace fs = std::filesystem;

// At most this many models side by side; a report of more (a sweep) shows the first.
constexpr std::size_t kMostModels = 8;

struct Row {
  std::size_t light = 0, view = 0;
  std::string label;
  std::vector<float> original;
};

const PicturedPair* find_pair(const ModelComparison& c, std::size_t light, std::size_t view) {
  for (const PicturedPair& p : c.pairs)
    if (p.light == light && p.view == view) return &p;
  return nullptr;
}

// The original image of (light, view): from `data` (the first model's tile), else from a pair
// the first model pictures; empty if neither holds it.
std::vector<float> original_image(const ModelComparison& first, const Btf* data, std::size_t l,
                                  std::size_t v) {
  if (data) return {data->image(l, v), data->image(l, v) + data->image_floats()};
  const PicturedPair* p = find_pair(first, l, v);
  return p ? p->original : std::vector<float>{};
}

// The pairs shown: the first model's two worst images by PSNR, then a typical one (its median
// PSNR; without the data, its frontal pair), each once.
std::vector<Row> chosen_rows(const ModelComparison& first, const Btf* data) {
  const std::vector<std::size_t> order = first.quality.by_psnr();
  const std::size_t nv = first.quality.views;
  std::vector<std::pair<std::size_t, std::string>> picks;
  for (std::size_t k = 0; k < std::min<std::size_t>(2, order.size()); ++k)
    picks.push_back({order[k], fmt::format("worst PSNR {} of {}", k + 1, svg::escape(first.name))});
  if (data && !order.empty())
    picks.push_back(
        {order[order.size() / 2], "typical: the median PSNR of " + svg::escape(first.name)});
  else if (!first.pairs.empty())
    picks.push_back({first.pairs[0].light * nv + first.pairs[0].view, "frontal light and view"});
  std::vector<Row> rows;
  for (const auto& [image, label] : picks) {
    const std::size_t l = image / nv, v = image % nv;
    if (std::any_of(rows.begin(), rows.end(),
                    [&](const Row& r) { return r.light == l && r.view == v; }))
      continue;
    Row r{.light = l, .view = v, .label = label, .original = original_image(first, data, l, v)};
    if (!r.original.empty()) rows.push_back(std::move(r));
  }
  return rows;
}

// The model's image of (light, view) at its tile's size: the one compare decoded where it is
// pictured, else decoded alone (the same seed for a synthesis).
std::vector<float> model_image(const ModelComparison& c, std::size_t l, std::size_t v) {
  if (const PicturedPair* p = find_pair(c, l, v)) return p->model;
  const ModelFrame& m = c.model->frame();
  const Btf one = c.model->decode(DirectionSet({m.lights[l]}), DirectionSet({m.views[v]}), m.width,
                                  m.height, kDecodeTolerance);
  return {one.image(0, 0), one.image(0, 0) + one.image_floats()};
}

// The objective a mixture was fitted for (the paper's likelihood or the prediction's error),
// as its provenance records it: ", objective likelihood"; empty where none is recorded.
std::string objective_text(const Representation& r) {
  for (const auto& [k, v] : r.provenance().fit.settings)
    if (k == "objective") return ", objective " + svg::escape(v);
  return "";
}

// The seed a synthesis is made from, as the model states it.
std::string synthesis_seed(const Representation& r) {
  for (const auto& [k, v] : r.details())
    if (k == "seed") return v;
  return "its own";
}

// A picture with its caption, the caption wrapped to the picture's width.
std::string figure(const std::string& png, int w, int h, const std::string& caption) {
  return fmt::format(
      "<figure style=\"width:{}px\"><img src=\"{}\" width=\"{}\" height=\"{}\" alt=\"\">"
      "<figcaption>{}</figcaption></figure>",
      std::max(w, 128), png, w, h, caption);
}

// A model's caption: its name (the file's stem), method and size (a mixture: its objective),
// true file bytes and the image's PSNR (a synthesis: none, it makes new texture).
std::string caption(const ModelComparison& c, std::size_t image) {
  std::string s = fmt::format(
      "<b>{}</b><br>{} {}{}<br>{}", svg::escape(fs::path(c.name).stem().string()),
      svg::escape(std::string(c.model->method())), svg::escape(c.model->size_text()),
      objective_text(*c.model),
      c.file_bytes > 0 ? fmt::format("file {} bytes", c.file_bytes) : std::string("no file"));
  if (c.model->synthesises())
    return s + fmt::format("<br><i>synthesis of new texture</i> (seed {}): no pixel-wise PSNR",
                           svg::escape(synthesis_seed(*c.model)));
  return s + fmt::format("<br>PSNR {} dB", db(c.quality.images[image].psnr_db));
}

// The data tiled 2 x 2 beside each synthesis made at twice the tile's size, at `row`'s pair.
std::string texture_block(const fs::path& folder, const std::vector<const ModelComparison*>& ms,
                          const Row& row, int f, double range) {
  const ModelFrame& m = ms[0]->model->frame();
  const int w = m.width, h = m.height;
  std::vector<float> tiled(std::size_t(4 * w * h) * 3);
  for (int y = 0; y < 2 * h; ++y)
    for (int x = 0; x < 2 * w; ++x)
      for (int k = 0; k < 3; ++k)
        tiled[(std::size_t(y) * std::size_t(2 * w) + std::size_t(x)) * 3 + std::size_t(k)] =
            row.original[(std::size_t(y % h) * std::size_t(w) + std::size_t(x % w)) * 3 +
                         std::size_t(k)];
  save_png(folder, "sbs_texture_data.png",
           upscale_nearest(display_image(tiled, 2 * w, 2 * h, m.format, range), f));
  std::string s = fmt::format(
      "<h3>Texture at twice the tile: light {}, view {}</h3><div class=\"imgs\" "
      "style=\"gap:10px;flex-wrap:wrap\">{}",
      angles(m.lights[row.light]), angles(m.views[row.view]),
      figure("sbs_texture_data.png", 2 * w * f, 2 * h * f,
             "<b>original</b>, the tile 2 &times; 2"));
  for (std::size_t k = 0; k < ms.size(); ++k) {
    const ModelComparison& c = *ms[k];
    if (!c.model->synthesises()) continue;
    const Btf big = c.model->decode(DirectionSet({m.lights[row.light]}),
                                    DirectionSet({m.views[row.view]}), 2 * w, 2 * h, 0.0);
    const std::string png = fmt::format("sbs_texture_m{}.png", k + 1);
    save_png(folder, png,
             upscale_nearest(display_image({big.image(0, 0), big.image_floats()}, 2 * w, 2 * h,
                                           m.format, range),
                             f));
    s += figure(png, 2 * w * f, 2 * h * f,
                fmt::format("<b>{}</b> {}<br>synthesised at {}&times;{} (seed {})",
                            svg::escape(fs::path(c.name).stem().string()),
                            svg::escape(std::string(c.model->method())), 2 * w, 2 * h,
                            svg::escape(synthesis_seed(*c.model))));
  }
  return s + "</div>";
}

}  // namespace

std::string side_by_side(const fs::path& folder, std::span<const ModelComparison> models,
                         const Btf* data) {
  std::vector<const ModelComparison*> ms;  // the models of the first model's tile
  std::size_t of_tile = 0;
  for (const ModelComparison& c : models)
    if (c.tile == models[0].tile && ++of_tile <= kMostModels) ms.push_back(&c);
  if (ms.size() < 2) return "";
  if (data && (data->width() != models[0].tile.width || data->height() != models[0].tile.height))
    data = nullptr;
  const std::vector<Row> rows = chosen_rows(models[0], data);
  if (rows.empty()) return "";
  const ModelFrame& m = models[0].model->frame();
  const double range = models[0].quality.range;
  const int f = upscale_for(std::max(m.width, m.height), 128), w = m.width * f, h = m.height * f;
  std::string s = fmt::format(
      "<section><h2>The models side by side</h2><div class=\"wide\"><div style=\"display:grid;"
      "grid-template-columns:repeat({},auto);gap:8px 10px;justify-content:start\">",
      ms.size() + 1);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const Row& row = rows[r];
    const std::string original = fmt::format("sbs_r{}_original.png", r + 1);
    save_png(folder, original,
             upscale_nearest(display_image(row.original, m.width, m.height, m.format, range), f));
    s += figure(original, w, h,
                fmt::format("<b>original</b>: {}<br>light {}<br>view {}", row.label,
                            angles(m.lights[row.light]), angles(m.views[row.view])));
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const std::string png = fmt::format("sbs_r{}_m{}.png", r + 1, k + 1);
      save_png(folder, png,
               upscale_nearest(display_image(model_image(*ms[k], row.light, row.view), m.width,
                                             m.height, m.format, range),
                               f));
      s += figure(png, w, h, caption(*ms[k], row.light * m.views.size() + row.view));
    }
  }
  s += "</div></div>";
  const bool synthesis = std::any_of(
      ms.begin(), ms.end(), [](const ModelComparison* c) { return c->model->synthesises(); });
  if (synthesis) s += texture_block(folder, ms, rows.back(), f, range);
  s += fmt::format(
      "<p class=\"note\">Rows: the (light, view) pairs where {} decodes worst, and a typical "
      "one; columns: the original, then each model of the tile{}, with its true file size and "
      "that image's PSNR. All on the original's scale, enlarged {} &times; without smoothing.{}"
      "</p></section>\n",
      svg::escape(models[0].name),
      of_tile > kMostModels ? fmt::format(" (the first {} of {})", kMostModels, of_tile)
                            : std::string(),
      f,
      synthesis ? " A synthesis model makes new texture with the data's statistics, so its "
                  "picture is not aligned with the data's pixels and has no pixel-wise PSNR; "
                  "judge it by eye and by the statistics of <code>compare</code>."
                : "");
  return s;
}

}  // namespace btfgmm::report
