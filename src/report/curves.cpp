// The report's curves: compression ratio against tile size (the paper's Fig. 4), the
// mixtures' PSNR against M, and rate-distortion with the Pareto front; see sections.hpp.
#include <algorithm>
#include <vector>

#include "btfgmm/model/model_file.hpp"
#include "btfgmm/report/chart.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace btfgmm::report {

namespace {

// The Gaussian mixtures among the models, in the order of M (ties in the order given).
std::vector<const ModelComparison*> mixtures_by_m(std::span<const ModelComparison> models) {
  std::vector<const ModelComparison*> out;
  for (const auto& x : models)
    if (x.model->method() == kMixtureMethod) out.push_back(&x);
  std::stable_sort(out.begin(), out.end(), [](auto* a, auto* b) {
    return a->model->size_order() < b->model->size_order();
  });
  return out;
}

Chart psnr_against_components_chart(std::span<const ModelComparison> models) {
  Chart c;
  c.title = "Gaussian mixtures: PSNR against M";
  c.x_label = "components M";
  c.x_integer = true;
  c.y_label = "PSNR (dB)";
  c.x_from_zero = true;
  ChartSeries s;
  s.label = "models compared";
  s.markers = true;
  double max_m = 0;
  for (auto* x : mixtures_by_m(models)) {
    s.points.push_back({x->model->size_order(), x->quality.psnr_db});
    max_m = std::max(max_m, x->model->size_order());
  }
  ChartSeries base;
  base.label = "mean BRDF alone (M = 0)";
  base.colour = "#9ca3af";
  base.dashed = true;
  const double base_psnr = models[0].mean_brdf_only.psnr_db;
  base.points = {{0.0, base_psnr}, {max_m, base_psnr}};
  c.series = {s, base};
  return c;
}

// The mixtures' convergence: L of Eq. (3) at each EM iteration, from their files' fit logs.
bool has_fit_log(const ModelComparison& x) {
  return !x.model->provenance().fit.iterations.empty();
}

Chart convergence_chart(std::span<const ModelComparison> models) {
  Chart c;
  c.title = "Gaussian mixtures: convergence of EM";
  c.x_label = "EM iteration";
  c.x_integer = true;
  c.y_label = "mean log-likelihood L (nats per sample)";
  for (auto* x : mixtures_by_m(models)) {
    if (!has_fit_log(*x)) continue;
    ChartSeries s;
    s.label = x->name + " (" + x->model->size_text() + ")";
    s.colour = svg::kPalette[c.series.size() % svg::kPaletteSize];
    const auto& its = x->model->provenance().fit.iterations;
    s.markers = its.size() <= 12;
    for (std::size_t i = 0; i < its.size(); ++i)
      s.points.push_back({double(i + 1), its[i].log_likelihood});
    c.series.push_back(s);
  }
  return c;
}

}  // namespace

std::string curves_section(std::span<const ModelComparison> models) {
  std::string curves = "<section><h2>Curves</h2><div class=\"curves\">";
  curves += svg_chart(rate_distortion_chart(models));
  curves += svg_chart(compression_ratio_chart(models));
  if (!mixtures_by_m(models).empty()) curves += svg_chart(psnr_against_components_chart(models));
  if (std::any_of(models.begin(), models.end(), [](const ModelComparison& x) {
        return x.model->method() == kMixtureMethod && has_fit_log(x);
      }))
    curves += svg_chart(convergence_chart(models));
  curves += "</div>";
  if (models.size() == 1)
    curves +=
        "<p class=\"note\">One model: compare several models of this BTF (e.g. fitted with "
        "different sizes, or by a sweep) to trace the rate-distortion curves.</p>";
  else
    curves +=
        "<p class=\"note\">Rate-distortion: each method's models joined in the order of their "
        "file's compression ratio; the wide grey steps are the Pareto front (the highest PSNR "
        "at a ratio or any larger, over all models); hollow markers place the same models by "
        "the paper's count. Models of other tiles are on the same axes. Convergence: each EM "
        "iteration's L is that of the parameters it started from (from the model files' fit "
        "logs).</p>";
  curves += "</section>\n";
  return curves;
}

}  // namespace btfgmm::report
