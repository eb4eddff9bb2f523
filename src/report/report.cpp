// The HTML report of models compared with their BTF tile: a page of cards, the table of
// models, the pictures of the paper's Fig. 3 and Fig. 2, a PSNR map per model, the curves,
// and how the numbers are measured; see report.hpp and docs/METRICS.md.
#include "btfgmm/report/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/model/model_file.hpp"
#include "report/grid.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace btfgmm {

namespace fs = std::filesystem;

namespace {

using svg::colour_bar;
using svg::escape;
using svg::grey_bar;
using svg::grid_svg;

using report::angles;
using report::db;
using report::ratio;
using report::rmse_text;
using report::save_png;
using report::tile_text;
using report::time_text;
using report::upscale_for;

// ---- files ---------------------------------------------------------------------------------

void create_report_folder(const fs::path& folder) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder))
    throw Error(Error::Kind::kIo, fmt::format("report: cannot create the folder '{}': {}; check "
                                              "the path and its permissions",
                                              folder.string(), ec.message()));
}

// ---- the page's head: title, style, what was compared -------------------------------------

constexpr const char kStyle[] = R"(<style>
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;color:#1f2937;background:#f3f4f6;margin:0}
main{max-width:1360px;margin:0 auto;padding:16px 22px}
h1{font-size:21px;margin:0 0 2px}h2{font-size:16px;margin:0 0 10px}h3{font-size:13px;margin:0 0 6px;color:#374151}
.sub{color:#4b5563;margin:0 0 12px}
section{background:#fff;border:1px solid #e5e7eb;border-radius:8px;padding:12px 16px;margin:0 0 12px}
.cards{display:flex;gap:10px;flex-wrap:wrap;margin:0 0 12px}
.card{flex:1;min-width:170px;background:#fff;border:1px solid #e5e7eb;border-radius:8px;padding:8px 12px}
.card .k{color:#6b7280;font-size:11px;text-transform:uppercase;letter-spacing:.05em}
.card .v{font-size:26px;font-weight:650;line-height:1.2}.card .v small{font-size:14px;font-weight:500;color:#6b7280}
.card .s{color:#6b7280;font-size:12px}
table{border-collapse:collapse;font-variant-numeric:tabular-nums;font-size:13px}
th,td{padding:3px 9px;border-bottom:1px solid #e5e7eb;text-align:right;white-space:nowrap}
th{background:#f9fafb;font-weight:600}td:first-child,th:first-child{text-align:left}
tr.base td{color:#6b7280;font-style:italic}
.detail{display:flex;gap:22px;align-items:flex-start;flex-wrap:wrap}
.pairs{display:grid;grid-template-columns:repeat(2,auto);gap:10px 22px}
figure{margin:0}.imgs{display:flex;gap:3px}.imgs span{display:block;font-size:11px;color:#6b7280;text-align:center}
img{image-rendering:pixelated;display:block;outline:1px solid #d1d5db}
figcaption{font-size:12px;color:#374151;margin-top:2px;overflow-wrap:anywhere}figcaption b{color:#111827}
.maps{display:flex;flex-direction:column;gap:8px;flex:0 0 auto}
.curves{display:flex;gap:14px;flex-wrap:wrap}
.note{color:#6b7280;font-size:12px;margin:6px 0 0}.wide{overflow-x:auto}
.ramp{display:inline-block;width:120px;height:10px;vertical-align:middle;background:linear-gradient(to right,#000,#fff);border:1px solid #9ca3af}
code{font-size:12px;background:#f3f4f6;padding:0 3px;border-radius:3px}
.notes li{margin:2px 0;font-size:13px}
</style></head><body><main>
)";

std::string page_head(const std::string& btf_name, std::span<const ModelComparison> models,
                      const ReportOptions& o) {
  const ModelFrame& m0 = models[0].model->frame();
  std::string h;
  h += "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">";
  h += fmt::format("<title>btfgmm {}: {}</title>", escape(o.command), escape(btf_name));
  h += kStyle;
  h += fmt::format("<h1>btfgmm {}: <code>{}</code></h1>", escape(o.command), escape(btf_name));
  h += fmt::format(
      "<p class=\"sub\">{} light &times; {} view directions ({} images) &middot; {} data &middot; "
      "{} model{} compared &middot; tile {}{}</p>",
      m0.lights.size(), m0.views.size(), m0.lights.size() * m0.views.size(), to_string(m0.format),
      models.size(), models.size() == 1 ? "" : "s", tile_text(models[0].tile),
      o.note.empty() ? "" : "<br>" + escape(o.note));
  return h;
}

// The figures of one model at a glance (a report of one model): PSNR, SSIM, RMSE, compression,
// components.
std::string cards(const ModelComparison& c) {
  const BtfQuality& q = c.quality;
  const auto& worst = q.images[q.worst_psnr];
  auto card = [](const std::string& k, const std::string& v, const std::string& sub) {
    return fmt::format(
        "<div class=\"card\"><div class=\"k\">{}</div><div class=\"v\">{}</div>"
        "<div class=\"s\">{}</div></div>",
        k, v, sub);
  };
  std::string s = "<div class=\"cards\">";
  s += card("PSNR", db(q.psnr_db) + " <small>dB</small>",
            fmt::format("worst image {} dB &middot; mean BRDF alone {} dB", db(worst.psnr_db),
                        db(c.mean_brdf_only.psnr_db)));
  s += card("SSIM", fmt::format("{:.3f}", q.ssim),
            fmt::format("worst image {:.3f} &middot; mean BRDF alone {:.3f}",
                        q.images[q.worst_ssim].ssim, c.mean_brdf_only.ssim));
  const SampleFormat format = c.model->frame().format;
  s += card("RMSE", rmse_text(q.rmse, format),
            fmt::format("{} &middot; mean BRDF alone {}",
                        format == SampleFormat::kHdr ? "data units" : "levels of 0-255",
                        rmse_text(c.mean_brdf_only.rmse, format)));
  s += card("Compression", ratio(c.model->paper_ratio()),
            c.file_bytes > 0 ? fmt::format("paper's count &middot; file {} ({})",
                                           ratio(c.model->file_ratio(c.file_bytes)),
                                           human_bytes(double(c.file_bytes)))
                             : std::string("paper's count"));
  std::string facts;
  for (const auto& [k, v] : c.model->details())
    facts += fmt::format("{}{}: {}", facts.empty() ? "" : " &middot; ", escape(k), escape(v));
  s += card("Model",
            fmt::format("{} <small>{}</small>", escape(std::string(c.model->method())),
                        escape(c.model->size_text())),
            facts);
  s += "</div>";
  return s;
}

// ---- the table of models ---------------------------------------------------------------------

// A model's row; `pareto`: it is on the Pareto front of PSNR against its file's ratio.
std::string model_row(const ModelComparison& c, bool pareto) {
  const BtfQuality& q = c.quality;
  const std::size_t w = q.worst_psnr;
  const ModelFrame& f = c.model->frame();
  return fmt::format(
      "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
      "<td>{}</td><td>{}</td><td>{:.3f}</td><td>{}<br><small>{}; "
      "{}</small></td><td>{}</td><td>{}</td>"
      "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
      escape(c.name), escape(std::string(c.model->method())), escape(c.model->size_text()),
      tile_text(c.tile), c.model->parameter_count(), rmse_text(q.rmse, f.format), db(q.psnr_db),
      q.ssim, db(q.images[w].psnr_db), angles(f.lights[w / q.views]), angles(f.views[w % q.views]),
      ratio(c.model->paper_ratio()), c.file_bytes ? ratio(c.model->file_ratio(c.file_bytes)) : "",
      c.file_bytes ? human_bytes(double(c.file_bytes)) : "", to_string(c.model->encoding()),
      // Recorded in the model's provenance since format version 3: blank when unknown.
      c.fit_seconds > 0 ? time_text(c.fit_seconds) : std::string(),
      c.decode_seconds > 0 ? time_text(c.decode_seconds) : std::string(), pareto ? "&#9733;" : "");
}

// The baseline: the mean BRDF alone, once per tile.
std::string mean_brdf_rows(std::span<const ModelComparison> models) {
  std::string h;
  std::vector<Tile> tiles_with_baseline;
  for (const ModelComparison& c : models) {
    const bool seen = std::any_of(tiles_with_baseline.begin(), tiles_with_baseline.end(),
                                  [&](const Tile& t) { return t == c.tile; });
    if (seen) continue;
    tiles_with_baseline.push_back(c.tile);
    const BtfQuality& b = c.mean_brdf_only;
    h += fmt::format(
        "<tr class=\"base\"><td>mean BRDF alone</td><td></td><td></td><td>{}</td><td>{}</td>"
        "<td>{}</td><td>{}</td><td>{:.3f}</td><td>{}</td><td></td><td></td><td></td><td></td>"
        "<td></td><td></td><td></td></tr>",
        tile_text(c.tile), c.model->frame().lights.size() * c.model->frame().views.size() * 3,
        rmse_text(b.rmse, c.model->frame().format), db(b.psnr_db), b.ssim,
        db(b.images[b.worst_psnr].psnr_db));
  }
  return h;
}

// The settings a sweep could not fit, and why.
std::string skipped_list(std::span<const SkippedSetting> skipped) {
  if (skipped.empty()) return "";
  std::string h =
      "<p class=\"note\">Not fitted (the method refused the setting for this "
      "tile):</p><ul class=\"note\">";
  for (const SkippedSetting& s : skipped)
    h += fmt::format("<li><b>{}</b> {}: {}</li>", escape(s.method), escape(s.settings),
                     escape(s.message));
  return h + "</ul>";
}

// The synthesis models' texture statistics against the data (measure/texture_statistics.hpp),
// which measure them where pixel-wise PSNR cannot.
std::string texture_table(std::span<const ModelComparison> models) {
  std::string rows;
  for (const ModelComparison& c : models) {
    if (!c.texture) continue;
    const TextureStatistics& t = *c.texture;
    rows += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{:.2f}</td><td>{:.2f}</td><td>{:.2f}&ndash;{:.2f}</td>"
        "<td>{:.3f}</td><td>{:.3f}</td><td>{:.2f}</td></tr>",
        escape(c.name), escape(c.model->size_text()), t.mean_difference, t.deviation_difference,
        t.lowest_deviation_ratio, t.highest_deviation_ratio, t.autocorrelation_difference,
        t.histogram_distance, t.worst_streak_ratio);
  }
  if (rows.empty()) return "";
  return fmt::format(
      "<h3>Synthesis models: texture statistics</h3><p class=\"note\">They make new texture "
      "with the data's statistics, so their pixel-wise PSNR measures nothing (they are not "
      "on the Pareto front). Per image, against the data image, averaged over the images: "
      "|mean difference| and |deviation difference| of the channels (levels), the deviation "
      "ratio model/data (lowest to highest), |normalised autocorrelation difference| at lags "
      "1&ndash;{}, the luminance histograms' total-variation distance (0 equal, 1 disjoint) "
      "and the largest row/column mean jump model/data (a streak).</p><div class=\"wide\">"
      "<table><tr><th>model</th><th>size</th><th>mean diff</th><th>deviation diff</th>"
      "<th>deviation ratio</th><th>autocorrelation diff</th><th>histogram distance</th>"
      "<th>streak ratio</th></tr>{}</table></div>",
      kTextureLags, rows);
}

std::string models_table(std::span<const ModelComparison> models, const ReportOptions& o) {
  std::string h =
      "<section><h2>Models</h2><div "
      "class=\"wide\"><table><tr><th>model</th><th>method</th><th>size</th><th>tile"
      "</th><th>values stored</th><th>RMSE</th><th>PSNR dB</th><th>SSIM</th><th>worst image PSNR "
      "(light; view)</th>"
      "<th>C.R. paper</th><th>C.R. file</th><th>file</th><th>precision</th><th>fit time</th>"
      "<th>decode</th>"
      "<th>Pareto</th></tr>";
  const std::vector<bool> front = pareto_front(models);
  for (std::size_t k = 0; k < models.size(); ++k) h += model_row(models[k], front[k]);
  h += mean_brdf_rows(models);
  h += "</table></div><p class=\"note\">The paper (Fig. 3, M = 600, 81 &times; 81 directions): "
       "corduroy 36&times;46 1:518, RMSE 15 / PSNR 24.8 dB / SSIM 0.81; knitted wool 25&times;25 "
       "1:196, 12 / 26.5 / 0.85; aluminium profile 21&times;26 1:171, 7.3 / 30.9 / 0.90. "
       "&ldquo;Mean BRDF alone&rdquo;: every pixel its image's mean colour, the model without "
       "its mixture. &#9733;: on the Pareto front (no model has a higher PSNR at the same or a "
       "higher compression ratio of its file). Decode: every image of the tile.</p>";
  h += texture_table(models);
  h += skipped_list(o.skipped);
  h += "</section>\n";
  return h;
}

// ---- one section per model: pictures, PSNR map, mean BRDF ----------------------------------

// One colour scale for the PSNR maps of all models; a model exact everywhere has no say in it.
std::array<double, 2> psnr_map_scale(std::span<const ModelComparison> models) {
  std::array<double, 2> map_range{};
  bool have_range = false;
  for (const ModelComparison& c : models) {
    if (std::none_of(c.quality.images.begin(), c.quality.images.end(),
                     [](const ImageQuality& iq) { return std::isfinite(iq.psnr_db); }))
      continue;
    const auto r = psnr_map_range(c.quality);
    map_range = have_range ? std::array<double, 2>{std::min(map_range[0], r[0]),
                                                   std::max(map_range[1], r[1])}
                           : r;
    have_range = true;
  }
  if (!have_range) map_range = {0.0, 1.0};
  return map_range;
}

// The paper's Fig. 3 for one pair: original | model | 10 x |difference|, each enlarged `f`
// times, with the pair's RMSE, PSNR and SSIM.
std::string pictured_pair(const fs::path& folder, std::size_t k, const ModelComparison& c,
                          const PicturedPair& p, int f) {
  const ModelFrame& m = c.model->frame();
  const BtfQuality& q = c.quality;
  const int w = m.width, hgt = m.height;
  const std::string stem = fmt::format("m{}_l{}_v{}", k + 1, p.light, p.view);
  save_png(folder, stem + "_original.png",
           upscale_nearest(display_image(p.original, w, hgt, m.format, q.range), f));
  save_png(folder, stem + "_model.png",
           upscale_nearest(display_image(p.model, w, hgt, m.format, q.range), f));
  save_png(folder, stem + "_difference.png",
           upscale_nearest(difference_image(p.original, p.model, w, hgt, m.format, q.range), f));
  const ImageQuality& iq = q.images[p.light * q.views + p.view];
  std::string h = "<figure><div class=\"imgs\">";
  for (const char* part : {"original", "model", "difference"})
    h += fmt::format(
        "<div><span>{}</span><img src=\"{}_{}.png\" width=\"{}\" height=\"{}\" "
        "alt=\"{}\"></div>",
        std::string(part) == "difference" ? "10 &times; |difference|" : part, stem, part, w * f,
        hgt * f, part);
  h += fmt::format(
      "</div><figcaption><b>{}</b>: light {}, view {}<br>RMSE {} &middot; PSNR {} dB "
      "&middot; SSIM {:.3f}</figcaption></figure>",
      escape(p.label), angles(m.lights[p.light]), angles(m.views[p.view]),
      rmse_text(iq.rmse, m.format), db(iq.psnr_db), iq.ssim);
  return h;
}

// The PSNR of every (light, view) image on the shared colour scale, the worst pictured
// outlined.
std::string psnr_map(const fs::path& folder, std::size_t k, const ModelComparison& c, int cell,
                     const std::vector<std::pair<std::size_t, std::size_t>>& outline,
                     std::array<double, 2> map_range) {
  const ModelFrame& m = c.model->frame();
  const auto [lo, hi] = map_range;
  const std::string map_png = fmt::format("m{}_psnr_map.png", k + 1);
  save_png(folder, map_png, upscale_nearest(psnr_map_image(c.quality, lo, hi), cell));
  std::string h = "<div><h3>PSNR of every (light, view) image</h3>";
  h += grid_svg(map_png, m.lights, m.views, cell, outline,
                colour_bar(lo, hi, int(m.lights.size()) * cell, fmt::format("psnrbar{}", k + 1)),
                48);
  h += "<p class=\"note\">Dark: the directions the model misses. Red squares: the worst images "
       "pictured.</p></div>";
  return h;
}

// The mean BRDF of the tile as the paper's Fig. 2.
std::string mean_brdf_picture(const fs::path& folder, std::size_t k, const ModelComparison& c,
                              int cell, bool hdr) {
  const ModelFrame& m = c.model->frame();
  const std::string brdf_png = fmt::format("m{}_mean_brdf.png", k + 1);
  save_png(folder, brdf_png,
           upscale_nearest(mean_brdf_image(c.mean_brdf, m.lights.size(), m.views.size(), m.format),
                           cell));
  const float peak = *std::max_element(c.mean_brdf.begin(), c.mean_brdf.end());
  std::string h = "<div><h3>Mean BRDF of the tile (the paper's Fig. 2)</h3>";
  h += grid_svg(brdf_png, m.lights, m.views, cell, {},
                grey_bar(0.0, double(peak), int(m.lights.size()) * cell,
                         fmt::format("brdfbar{}", k + 1), hdr ? "value" : "levels"),
                48);
  h += fmt::format(
      "<p class=\"note\">Rows: lights, columns: views, each ring from &phi; = 0. "
      "Scaled so that the brightest value of any channel ({:.4g}{}) is full intensity{}.</p></div>",
      peak, hdr ? "" : " levels", hdr ? ", sRGB-encoded (the bar is linear)" : "");
  return h;
}

// Model k's section: its pictured pairs, its PSNR map and (for a tile not shown yet) the mean
// BRDF. Writes the section's PNG pictures into `folder`.
std::string model_section(const fs::path& folder, std::span<const ModelComparison> models,
                          std::size_t k, std::array<double, 2> map_range) {
  const ModelComparison& c = models[k];
  const ModelFrame& m = c.model->frame();
  const int f = upscale_for(std::max(m.width, m.height), 128);
  const bool hdr = m.format == SampleFormat::kHdr;
  std::string h = fmt::format(
      "<section><h2>{}: original | model | 10 &times; |difference|</h2>"
      "<p class=\"note\">10 &times; |difference|, per channel: <span class=\"ramp\"></span> "
      "black: exact, white: {} or more off.</p>"
      "<div class=\"detail\"><div class=\"pairs\">",
      escape(c.name),
      hdr ? fmt::format("{:g} (a tenth of the data's peak, {:g})", c.quality.range / 10.0,
                        c.quality.range)
          : std::string("25.5 levels (of 0-255)"));
  std::vector<std::pair<std::size_t, std::size_t>> outline;
  for (const PicturedPair& p : c.pairs) {
    h += pictured_pair(folder, k, c, p, f);
    if (p.label.find("worst") != std::string::npos) outline.push_back({p.light, p.view});
  }
  const int largest = int(std::max(m.lights.size(), m.views.size()));
  const int cell = std::max(1, 250 / largest);
  h += fmt::format("</div><div class=\"maps\" style=\"width:{}px\">",
                   std::max(300, 46 + int(m.views.size()) * cell + 8 + 48 + 8));
  h += psnr_map(folder, k, c, cell, outline, map_range);
  if (k == 0 || c.tile != models[0].tile)
    h += mean_brdf_picture(folder, k, c, cell,
                           models[0].model->frame().format == SampleFormat::kHdr);
  h += "</div></div></section>\n";
  return h;
}

// ---- how the numbers are measured ------------------------------------------------------------

std::string measurement_notes(const ModelComparison& first) {
  const ModelFrame& m0 = first.model->frame();
  const bool hdr = m0.format == SampleFormat::kHdr;
  const int window = first.quality.ssim_window;
  std::string h = "<section class=\"notes\"><h2>How these numbers are measured</h2><ul>";
  h += fmt::format(
      "<li><b>RMSE</b> over all {} images, pixels and channels, {}; <b>PSNR</b> = "
      "20&nbsp;log<sub>10</sub>(R&nbsp;/&nbsp;RMSE) with R = {} of that RMSE.</li>",
      m0.lights.size() * m0.views.size(), hdr ? "in the data's units" : "on the 0-255 scale",
      hdr ? fmt::format("{:g} (the peak of the "
                        "original, HDR data)",
                        first.quality.range)
          : std::string("255"));
  h += fmt::format(
      "<li><b>SSIM</b> (Wang et al. 2004): {}&times;{} Gaussian window, &sigma; = 1.5, K1 = 0.01, "
      "K2 = 0.03, L = R, no padding; per channel, averaged over channels and images{}.</li>",
      window, window,
      window < 11 ? fmt::format(" (the tile is smaller than 11 pixels: the window shrinks to "
                                "{}&times;{}, the same Gaussian cut at its edge)",
                                window, window)
                  : std::string());
  h += "<li><b>Compression ratio</b>, the paper's count (Table 2): for the Gaussian mixture "
       "W&middot;H&middot;ni&middot;nv&middot;3 bytes of 8-bit data against M&middot;9&middot;2 "
       "four-byte floats plus the mean BRDF as ni&middot;nv&middot;3 bytes; for the other "
       "methods the data's values against the values stored, one for one. By the file: the "
       "same data, a byte a value, against the bytes of the model file.</li>";
  h += "<li><b>Pictures</b>: the tile enlarged without smoothing; differences are "
       "10&nbsp;&times;&nbsp;|original&nbsp;&minus;&nbsp;model|, as in the paper's Fig. 3.</li>";
  h += "</ul></section>\n</main></body></html>\n";
  return h;
}

}  // namespace

void write_report(const fs::path& folder, const std::string& btf_name,
                  std::span<const ModelComparison> models, const ReportOptions& options) {
  if (models.empty())
    throw Error(Error::Kind::kArgument, "report: give at least one model to compare");
  create_report_folder(folder);
  // One model: its cards first and its curves last; a sweep of models: the curves right after
  // the table.
  const bool one = models.size() == 1;
  std::string h = page_head(btf_name, models, options);
  if (one) h += cards(models[0]);
  h += models_table(models, options);
  const std::string curves = report::curves_section(models);
  if (!one)
    h += curves + report::methods_figure(folder, models) +
         report::side_by_side(folder, models, options.data);
  const std::array<double, 2> map_range = psnr_map_scale(models);
  for (std::size_t k = 0; k < models.size(); ++k) h += model_section(folder, models, k, map_range);
  if (one) h += curves;
  h += measurement_notes(models[0]);
  write_file_atomically(folder / "index.html",
                        {reinterpret_cast<const std::uint8_t*>(h.data()), h.size()}, "report");
}

}  // namespace btfgmm
