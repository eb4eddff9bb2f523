// em_probe: runs the reference EM (Eq. 3-7) on samples and starting parameters read from a
// text file and prints the mean log-likelihood of every iteration, for the independent check
// against scikit-learn (tests/sklearn_em_check.py).
//
// Input: "N M ITERATIONS", then N lines of 9 sample values, then M lines of
// "weight mean_1..mean_9 variance_1..variance_9".
// Output: one line of space-separated log-likelihoods, iteration 1 first.
#include <cstdio>
#include <fstream>
#include <iostream>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/em_reference.hpp"
#include "btfgmm/model/mixture.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: em_probe INPUT\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  std::size_t n = 0, m = 0;
  int iterations = 0;
  if (!(in >> n >> m >> iterations)) {
    std::fprintf(stderr, "em_probe: cannot read the header of %s\n", argv[1]);
    return 2;
  }
  std::vector<double> x(n * btfgmm::kVariables);
  for (double& v : x) in >> v;
  btfgmm::ProductMixture mix;
  mix.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    in >> mix.weight[k];
    for (double& v : mix.mean[k]) in >> v;
    for (double& v : mix.var[k]) in >> v;
  }
  if (!in) {
    std::fprintf(stderr, "em_probe: %s is shorter than its header says\n", argv[1]);
    return 2;
  }
  btfgmm::EmConfig c;
  c.max_iterations = iterations;
  c.variance_floor = 1e-300;      // no floor: scikit-learn has none (reg_covar = 0)
  c.min_component_samples = 0.0;  // nor does it drop components
  try {
    const auto r = btfgmm::fit_em_reference(x, mix, c);
    for (std::size_t i = 0; i < r.log_likelihood.size(); ++i)
      std::printf("%s%.17g", i ? " " : "", r.log_likelihood[i]);
    std::printf("\n");
  } catch (const btfgmm::Error& e) {
    std::fprintf(stderr, "em_probe: %s\n", e.what());
    return 1;
  }
  return 0;
}
