// Adam (Kingma & Ba 2015, "Adam: A method for stochastic optimization", Algorithm 1): the one
// optimiser of the library's gradient fits, the mixture's refinement for the prediction
// (model/refine_gradient.cpp) and the neural BTF's network and latents
// (methods/neural_network.hpp).
#pragma once

#include <cassert>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

namespace btfgmm {

// The term added to the root of the second moment, which keeps a step finite where a
// parameter's gradient has been zero at every step: in double the refinement's 1e-300, which
// changes no other step; float has no number that small, so there Kingma & Ba's 1e-8.
template <class Real>
constexpr Real adam_epsilon() {
  if constexpr (std::is_same_v<Real, double>)
    return 1e-300;
  else
    return Real(1e-8);
}

// Adam on a parameter vector, its moments and step count kept between steps: beta1 = 0.9,
// beta2 = 0.999, the moments bias-corrected (Algorithm 1). Every step takes the same operations
// in the same order, whatever the rate of each parameter.
template <class Real>
struct Adam {
  std::vector<Real> theta, m1, m2;  // the parameters, the first and second moments
  int t = 0;                        // the steps taken
  Real epsilon = adam_epsilon<Real>();

  explicit Adam(std::vector<Real> start, Real eps = adam_epsilon<Real>())
      : theta(std::move(start)),
        m1(theta.size(), Real(0)),
        m2(theta.size(), Real(0)),
        epsilon(eps) {}

  // One step along `grad`, parameter i at the rate rate_of(i) (Algorithm 1's alpha) with
  // epsilon_of(i) added to the root of its second moment.
  template <class RateOf, class EpsilonOf>
  requires std::invocable<const RateOf&, std::size_t> &&
      std::invocable<const EpsilonOf&, std::size_t>
  void step(std::span<const Real> grad, const RateOf& rate_of, const EpsilonOf& epsilon_of) {
    assert(grad.size() == theta.size());
    ++t;
    const Real c1 = Real(1.0 - std::pow(0.9, t)), c2 = Real(1.0 - std::pow(0.999, t));
    for (std::size_t i = 0; i < theta.size(); ++i) {
      m1[i] = Real(0.9) * m1[i] + Real(0.1) * grad[i];
      m2[i] = Real(0.999) * m2[i] + Real(0.001) * grad[i] * grad[i];
      const Real r = rate_of(i);
      theta[i] -= r * (m1[i] / c1) / (std::sqrt(m2[i] / c2) + epsilon_of(i));
    }
  }

  // One step along `grad`, parameter i at the rate rate_of(i), every parameter with `epsilon`.
  template <class RateOf>
  requires std::invocable<const RateOf&, std::size_t>
  void step(std::span<const Real> grad, const RateOf& rate_of) {
    const Real e = epsilon;
    step(grad, rate_of, [e](std::size_t) { return e; });
  }

  // One step along `grad`, every parameter at `rate`.
  void step(std::span<const Real> grad, Real rate) {
    step(grad, [rate](std::size_t) { return rate; });
  }
};

}  // namespace btfgmm
