// The 9-D Gaussian mixture of product components (the paper's Eq. 1-2) and its EM fit
// (Eq. 3-7).
//
// Variables are expressed in units of their quantisation step (docs/ALGORITHM.md): x, y in
// pixels, the four onion-slice angles in units of the angular sampling step of their
// direction set, the three colour residuals in 8-bit levels (HDR: in 1/255 of the data's
// range). One variance floor, 1/12 unit², then serves all nine variables.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"

namespace btfgmm {

constexpr int kVariables = 9;  // x, y, alpha_i, beta_i, alpha_v, beta_v, r, g, b
constexpr int kInputs = 6;     // the inputs I = {1..6} of Eq. (8)-(10)
// The variance floor, in units of each variable's quantisation step squared: the variance
// of a uniform distribution over one step (docs/ALGORITHM.md, "Units and the variance floor").
constexpr double kVarianceFloor = 1.0 / 12.0;

// The tile the spatial variables x, y repeat on, in pixels (their model units): x is periodic
// with period `width`, y with period `height`, and the Gaussians of x and y wrap around the
// tile (docs/ALGORITHM.md, "The tile wraps"). 0: that variable does not wrap (samples that
// are not a tile's).
struct TilePeriod {
  double width = 0.0, height = 0.0;
};

// The largest standard deviation of a wrapped variable, as a fraction of its period: the
// wrapped Gaussians are evaluated in the minimum image (the nearest copy of the mean only),
// which is exact to within about 2 exp(-(P/2)^2 / (2 sigma^2)) = 2 e^-8 = 7e-4 of the
// component's peak density at sigma = P/8 (docs/ALGORITHM.md, "The tile wraps"). EM keeps
// sigma_x <= W/8 and sigma_y <= H/8.
constexpr double kMaxWrappedDeviation = 0.125;

// P(x) = sum_m w_m prod_n N(x_n | mu_mn, sigma_mn^2)   (Eq. 1-2)
struct ProductMixture {
  std::vector<double> weight;                        // w_m, sum 1
  std::vector<std::array<double, kVariables>> mean;  // mu_mn
  std::vector<std::array<double, kVariables>> var;   // sigma_mn^2

  std::size_t size() const { return weight.size(); }
  void resize(std::size_t m) {
    weight.resize(m);
    mean.resize(m);
    var.resize(m);
  }
};

struct EmConfig {
  int max_iterations = 40;  // stop after this many iterations
  double epsilon = 0.0;     // ... or when the relative gain of L falls below this
  double variance_floor = kVarianceFloor;
  // A component whose summed responsibility falls below this many samples has vanished
  // ("suppressed by EM"): it is dropped from the mixture.
  double min_component_samples = 1.0;
  int threads = 0;  // 0: all cores
  // Checked after every iteration: when set, the fit stops there (EmResult::interrupted) and
  // can be resumed from the state it returns.
  const std::atomic<bool>* stop = nullptr;
  // After the last iteration, one more E pass (without statistics) gives L of the returned
  // parameters (EmResult::final_log_likelihood); off, that field is NaN.
  bool final_log_likelihood = true;
  // x and y wrap around the tile (docs/ALGORITHM.md, "The tile wraps"), as every evaluator of
  // a model assumes. Off, EM fits the paper's plain model, unwrapped; only to compare with
  // other implementations of that model (bench_fit beside Armadillo's gmm_diag).
  bool tile_wraps = true;
  // The compute device that sums the E pass (gpu/compute_device.hpp, docs/GPU.md); null: this
  // machine's threads. The same statistics either way, up to the order of float sums.
  std::shared_ptr<ComputeDevice> device;
};

// One EM iteration as it finished: L of Eq. (3) for the parameters the iteration started
// from, its relative gain over the previous iteration, components alive after the M-step.
struct EmProgress {
  int iteration = 0;  // 1-based
  int max_iterations = 0;
  double log_likelihood = 0.0;
  double relative_gain = 0.0;  // (L - L_prev) / |L_prev|; NaN for the first iteration (none)
  std::size_t components = 0;
  std::size_t dropped = 0;  // dropped so far
  double seconds = 0.0;     // since the fit started (a resumed fit's earlier runs included)
};
using EmCallback = std::function<void(const EmProgress&)>;

// Where an EM run's time went, summed over its iterations (seconds, wall clock): the tables of
// Eq. (2), the E pass (Eq. 3-4 and the statistics of each light), and the rest (the lights'
// statistics combined and the M-step, Eq. 5-7). Not kept in checkpoints.
struct EmStageSeconds {
  double tables = 0.0, e_pass = 0.0, m_step = 0.0;
};

struct EmResult {
  std::vector<double> log_likelihood;     // L per iteration (before its M-step)
  std::vector<double> seconds;            // per iteration: EmProgress::seconds at its end
  std::vector<std::uint32_t> components;  // per iteration: alive after its M-step
  double final_log_likelihood = 0.0;      // L of the returned parameters
  int iterations = 0;
  std::size_t dropped = 0;
  bool converged = false;    // stopped by epsilon
  bool interrupted = false;  // stopped by EmConfig::stop; resume from the returned state
  EmStageSeconds stages;
};

}  // namespace btfgmm
