// refit_probe: writes a small least-squares problem of the colour means and btfgmm's solution
// of it, for the independent check against numpy's lstsq (tests/numpy_refit_check.py).
//
// Usage: refit_probe OUTDIR. Writes, as raw little-endian float64:
//   OUTDIR/samples.f64   N x 9, every sample's nine variables in model units
//   OUTDIR/mixture.f64   M x 19, per component: w_m, mu_m1..9, sigma^2_m1..9 (EM's fit)
//   OUTDIR/refit.f64     M x 3, the colour means refit_colour_means makes of them
// and OUTDIR/problem.txt: "N M W H ridge error_before error_after" (lambda as used; the
// prediction's squared error over all channels before and after, model units).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "btfgmm/model/em.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/synth/generate.hpp"

namespace {

void write(const std::filesystem::path& p, const std::vector<double>& v) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * 8));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: refit_probe OUTDIR\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  btfgmm::GenerateConfig g;
  g.material = "knit";
  g.size = 6;
  g.seed = 4;
  g.lights = btfgmm::DirectionSet::rings({{0, 1}, {40, 5}});
  g.views = btfgmm::DirectionSet::rings({{0, 1}, {40, 3}});
  const btfgmm::SampleSet s = btfgmm::make_sample_set(btfgmm::generate(g));
  btfgmm::ProductMixture mix = btfgmm::initial_mixture(s, 12, 9);
  btfgmm::EmConfig em;
  em.max_iterations = 8;
  em.threads = 1;
  btfgmm::fit_em(s, mix, em);
  std::vector<double> samples, params;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (double v : s.sample(i)) samples.push_back(v);
  for (std::size_t m = 0; m < mix.size(); ++m) {
    params.push_back(mix.weight[m]);
    for (double v : mix.mean[m]) params.push_back(v);
    for (double v : mix.var[m]) params.push_back(v);
  }
  const btfgmm::ColourNormalEquations eq = btfgmm::colour_normal_equations(s, mix, 2);
  const btfgmm::ColourRefit r = btfgmm::refit_colour_means(eq, mix, 1e-3);
  std::vector<double> refit;
  for (std::size_t m = 0; m < mix.size(); ++m)
    for (int c = 0; c < 3; ++c) refit.push_back(mix.mean[m][std::size_t(6 + c)]);
  write(dir / "samples.f64", samples);
  write(dir / "mixture.f64", params);
  write(dir / "refit.f64", refit);
  std::FILE* f = std::fopen((dir / "problem.txt").c_str(), "w");
  std::fprintf(f, "%zu %zu %d %d %.17g %.17g %.17g\n", s.size(), mix.size(), s.width, s.height,
               r.ridge, r.error_before, r.error_after);
  std::fclose(f);
  return 0;
}
