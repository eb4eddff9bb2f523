// The same (light, view) image decoded by each method beside the original; see sections.hpp.
#include <cmath>
#include <limits>
#include <vector>

#include "btfgmm/report/pictures.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace btfgmm::report {

namespace {

// The compression ratio a model is placed by: its file's, or the paper's count without one.
double model_ratio(const ModelComparison& c) {
  return c.file_bytes > 0 ? c.model->file_ratio(c.file_bytes) : c.model->paper_ratio();
}

// The median of the models' ratios: the compression the figure compares the methods at.
double median_ratio(const std::vector<const ModelComparison*>& models) {
  std::vector<double> r;
  for (const auto* c : models) r.push_back(model_ratio(*c));
  std::sort(r.begin(), r.end());
  const std::size_t n = r.size();
  return n % 2 ? r[n / 2] : std::sqrt(r[n / 2 - 1] * r[n / 2]);
}

// Per method (in the order they first appear), its model nearest to `target` on a log scale
// (ties: the higher PSNR).
std::vector<const ModelComparison*> one_per_method(const std::vector<const ModelComparison*>& ms,
                                                   double target) {
  std::vector<const ModelComparison*> chosen;
  for (const ModelComparison* c : ms) {
    auto same = std::find_if(chosen.begin(), chosen.end(), [&](const ModelComparison* x) {
      return x->model->method() == c->model->method();
    });
    if (same == chosen.end()) {
      chosen.push_back(c);
      continue;
    }
    const double d = std::abs(std::log(model_ratio(*c) / target)),
                 best = std::abs(std::log(model_ratio(**same) / target));
    if (d < best || (d == best && c->quality.psnr_db > (*same)->quality.psnr_db)) *same = c;
  }
  return chosen;
}

const PicturedPair* find_pair(const ModelComparison& c, std::size_t light, std::size_t view) {
  for (const PicturedPair& p : c.pairs)
    if (p.light == light && p.view == view) return &p;
  return nullptr;
}

std::string picture(const std::string& png, int w, int h, const std::string& caption) {
  return fmt::format(
      "<figure><img src=\"{}\" width=\"{}\" height=\"{}\" alt=\"\"><figcaption>{}</figcaption>"
      "</figure>",
      png, w, h, caption);
}

}  // namespace

std::string methods_figure(const std::filesystem::path& folder,
                           std::span<const ModelComparison> models) {
  if (models.size() < 2 || models[0].pairs.empty()) return "";
  std::vector<const ModelComparison*> same;  // the models of the first model's tile
  for (const ModelComparison& c : models)
    if (c.tile == models[0].tile) same.push_back(&c);
  const double target = median_ratio(same);
  const PicturedPair& first = models[0].pairs[0];  // frontal light and view
  const ModelFrame& m = models[0].model->frame();
  const double range = models[0].quality.range;
  const int f = upscale_for(std::max(m.width, m.height), 128), w = m.width * f, h = m.height * f;
  save_png(folder, "methods_original.png",
           upscale_nearest(display_image(first.original, m.width, m.height, m.format, range), f));
  std::string s = fmt::format(
      "<section><h2>One image decoded by each method</h2><div class=\"imgs\" "
      "style=\"gap:10px;flex-wrap:wrap\">{}",
      picture("methods_original.png", w, h,
              fmt::format("<b>original</b><br>light {}<br>view {}", angles(m.lights[first.light]),
                          angles(m.views[first.view]))));
  const std::size_t image = first.light * m.views.size() + first.view;
  std::size_t k = 0;
  for (const ModelComparison* c : one_per_method(same, target)) {
    const PicturedPair* p = find_pair(*c, first.light, first.view);
    if (!p) continue;
    const std::string png = fmt::format("methods_{}.png", ++k);
    save_png(folder, png,
             upscale_nearest(display_image(p->model, m.width, m.height, m.format, range), f));
    s += picture(png, w, h,
                 fmt::format("<b>{}</b> {}<br>{} &middot; {} dB<br>{}",
                             svg::escape(std::string(c->model->method())),
                             svg::escape(c->model->size_text()), ratio(model_ratio(*c)),
                             db(c->quality.images[image].psnr_db), svg::escape(c->name)));
  }
  s += fmt::format(
      "</div><p class=\"note\">The image of the frontal light and view (the directions "
      "nearest the pole) as each method decodes it: per method its model whose compression "
      "ratio is nearest to {} (the median of the models'), with that image's PSNR. On the "
      "original's scale, enlarged without smoothing.</p></section>\n",
      ratio(target));
  return s;
}

}  // namespace btfgmm::report
