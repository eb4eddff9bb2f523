// One light's sufficient statistics from its sums per table column (em_light_statistics.hpp).
#include "model/em_light_statistics.hpp"

namespace btfgmm::detail {

std::vector<double> light_statistics(const SampleSet& s, const Tables& t, const ProductMixture& mix,
                                     std::size_t l, const ColumnSums& sums,
                                     const Periods& periods) {
  const std::size_t st = t.stride;
  std::vector<double> out(1 + t.m * kPerComponent, 0.0);
  out[0] = sums.ll;
  for (std::size_t k = 0; k < t.m; ++k) {
    const std::size_t m = t.order[k];  // table column k holds component m
    double* o = &out[1 + m * kPerComponent];
    double* s1 = o + 1;
    double* s2 = o + 1 + kVariables;
    const auto& mu = mix.mean[m];
    auto add = [&](int n, double q, double x) {
      const double d = wrapped_difference(x - mu[n], periods[std::size_t(n)]);
      s1[n] += q * d;
      s2[n] += q * d * d;
    };
    o[0] = sums.q[k];
    s1[0] = sums.xy[k];
    s2[0] = sums.xy[st + k];
    s1[1] = sums.xy[2 * st + k];
    s2[1] = sums.xy[3 * st + k];
    add(2, sums.q[k], s.light_ab[l][0]);
    add(3, sums.q[k], s.light_ab[l][1]);
    for (int n = 4; n < 6; ++n) {
      s1[n] = sums.views[std::size_t(2 * (n - 4)) * st + k];
      s2[n] = sums.views[std::size_t(2 * (n - 4) + 1) * st + k];
    }
    for (int c = 0; c < 3; ++c) {
      s1[6 + c] = sums.c1[std::size_t(c) * st + k];
      s2[6 + c] = sums.c2[std::size_t(c) * st + k];
    }
  }
  return out;
}

}  // namespace btfgmm::detail
