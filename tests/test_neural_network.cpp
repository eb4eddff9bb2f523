// The neural BTF's network (methods/neural_network.hpp) and Adam (core/adam.hpp): the gradient
// against central differences, a forward pass computed by hand, a student network learning a
// teacher of its shape, the batched gradient the same bit for bit on 1, 2 and 3 threads, and
// Adam's first two steps computed by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "core/adam.hpp"
#include "core/random.hpp"
#include "methods/neural_network.hpp"

namespace btfgmm {
namespace {

using detail::NetworkShape;

// n values uniform in [lo, hi) from `seed`.
template <class Real>
std::vector<Real> uniform_values(std::size_t n, std::uint64_t seed, double lo, double hi) {
  detail::SplitMix64 draw(seed);
  std::vector<Real> v(n);
  for (Real& x : v) x = Real(draw.uniform(lo, hi));
  return v;
}

// `samples` rows of network inputs: a latent uniform in [-1, 1) and the encoding of a light and
// a view drawn over the upper hemisphere (elevations up to 80 degrees).
std::vector<float> random_inputs(const NetworkShape& shape, std::size_t samples,
                                 std::uint64_t seed) {
  const std::size_t n = detail::input_size(shape);
  detail::SplitMix64 draw(seed);
  std::vector<float> x(samples * n);
  const auto direction = [&draw] {
    return to_vector({.theta_deg = draw.uniform(0.0, 80.0), .phi_deg = draw.uniform(0.0, 360.0)});
  };
  for (std::size_t s = 0; s < samples; ++s) {
    float* row = &x[s * n];
    for (std::size_t i = 0; i < shape.latent; ++i) row[i] = float(draw.uniform(-1.0, 1.0));
    const Vec3 light = direction(), view = direction();
    detail::encode_directions(light, view, {row + shape.latent, detail::kDirectionInputs});
  }
  return x;
}

// The network's outputs for the inputs x.
template <class Real>
std::vector<Real> outputs_of(const NetworkShape& shape, std::span<const Real> theta,
                             std::span<const Real> x) {
  std::vector<Real> y(x.size() / detail::input_size(shape) * detail::kNetworkOutputs);
  detail::forward(shape, theta, x, y);
  return y;
}

// E = sum of c_k y_k over the batch's outputs: dE/dy = c.
double weighted_output_sum(const NetworkShape& shape, std::span<const double> theta,
                           std::span<const double> x, std::span<const double> c) {
  const std::vector<double> y = outputs_of(shape, theta, x);
  double e = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) e += c[k] * y[k];
  return e;
}

// dE/dv[i] by central differences of step h.
double central_difference(const NetworkShape& shape, std::vector<double>& theta,
                          std::vector<double>& x, std::span<const double> c, std::vector<double>& v,
                          std::size_t i, double h) {
  const double at = v[i];
  v[i] = at + h;
  const double up = weighted_output_sum(shape, theta, x, c);
  v[i] = at - h;
  const double down = weighted_output_sum(shape, theta, x, c);
  v[i] = at;
  return (up - down) / (2.0 * h);
}

// In double the central difference of step 1e-6 is within about 1e-9 of the derivative (its
// truncation error h^2 f''' / 6 ~ 1e-12, its rounding ~ 1e-16 |E| / h ~ 1e-9): 1e-7 leaves a
// margin and still catches any wrong term (the gradients are of order 0.1 to 10). No
// pre-activation lies within h of the leaky ReLU's kink for these draws.
TEST(NeuralNetwork, GradientMatchesCentralDifferences) {
  const NetworkShape shape{.latent = 2, .width = 5, .depth = 2};
  const std::size_t batch = 6, n = detail::input_size(shape);
  std::vector<double> theta = uniform_values<double>(detail::parameter_count(shape), 1, -1, 1);
  std::vector<double> x = uniform_values<double>(batch * n, 2, -1, 1);
  const std::vector<double> c = uniform_values<double>(batch * 3, 3, -1, 1);
  std::vector<double> d_theta(theta.size()), d_x(x.size());
  detail::backward(shape, theta, x, c, d_theta, d_x);
  constexpr double kStep = 1e-6, kTolerance = 1e-7;
  for (std::size_t i = 0; i < theta.size(); ++i)
    EXPECT_NEAR(d_theta[i], central_difference(shape, theta, x, c, theta, i, kStep), kTolerance)
        << "parameter " << i;
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_NEAR(d_x[i], central_difference(shape, theta, x, c, x, i, kStep), kTolerance)
        << "input " << i % n << " of sample " << i / n;
  EXPECT_GT(*std::max_element(d_x.begin(), d_x.end()), 0.1);  // a gradient, not zeros
}

// The float pass computes what the double one does, to float's precision (a few ulps of the
// largest terms summed: 1e-4 of the gradient's largest magnitude).
TEST(NeuralNetwork, FloatGradientFollowsDouble) {
  const NetworkShape shape{.latent = 4, .width = 16, .depth = 3};
  const std::vector<float> theta = detail::initial_parameters(shape, 4);
  const std::vector<float> x = random_inputs(shape, 100, 5);
  const std::vector<float> c = uniform_values<float>(300, 6, -1, 1);
  std::vector<float> g(theta.size()), gx(x.size());
  detail::backward(shape, theta, x, c, g, gx);
  const std::vector<double> theta_d(theta.begin(), theta.end()), x_d(x.begin(), x.end()),
      c_d(c.begin(), c.end());
  std::vector<double> g_d(theta.size()), gx_d(x.size());
  detail::backward(shape, theta_d, x_d, c_d, g_d, gx_d);
  double largest = 0.0;
  for (double v : g_d) largest = std::max(largest, std::abs(v));
  for (std::size_t i = 0; i < g.size(); ++i) EXPECT_NEAR(g[i], g_d[i], 1e-4 * largest) << i;
  for (std::size_t i = 0; i < gx.size(); ++i) EXPECT_NEAR(gx[i], gx_d[i], 1e-4 * largest) << i;
}

// One hidden layer of two units on a latent of one value: n_0 = 10, 31 parameters, set by hand.
// Sample 0, x = (2, 1, 0, ..., 0, 3):
//   z = W0 x + b0 = (2 + 0.5 - 1, -4 + 1.5 + 0) = (1.5, -2.5), a = (1.5, -0.025)
//   y = W1 a + b1 = (1.5 + 0.5, 100 (-0.025), 2 (1.5) - 40 (-0.025) - 1) = (2, -2.5, 3)
// Sample 1, x = 0: z = b0 = (-1, 0), a = (-0.01, 0), y = (0.49, 0, -1.02).
TEST(NeuralNetwork, ForwardGivesTheValueComputedByHand) {
  const NetworkShape shape{.latent = 1, .width = 2, .depth = 1};
  ASSERT_EQ(detail::input_size(shape), 10u);
  ASSERT_EQ(detail::parameter_count(shape), 31u);
  const std::vector<detail::LayerLayout> layers = detail::layer_layout(shape);
  ASSERT_EQ(layers.size(), 2u);
  EXPECT_EQ(layers[0].biases, 20u);
  EXPECT_EQ(layers[1].weights, 22u);
  EXPECT_EQ(layers[1].biases, 28u);
  // W0 row-major (2 x 10), b0, W1 row-major (3 x 2), b1.
  const std::vector<float> theta = {1,    0.5f, 0, 0,   0, 0,   0, 0, 0, 0,     //
                                    -2,   0,    0, 0,   0, 0,   0, 0, 0, 0.5f,  //
                                    -1,   0,                                    //
                                    1,    0,    0, 100, 2, -40,                 //
                                    0.5f, 0,    -1};
  std::vector<float> x(20, 0.0f);
  x[0] = 2;
  x[1] = 1;
  x[9] = 3;
  const std::vector<float> y = outputs_of<float>(shape, theta, x);
  const std::vector<float> expected = {2, -2.5f, 3, 0.49f, 0, -1.02f};
  ASSERT_EQ(y.size(), expected.size());
  for (std::size_t i = 0; i < y.size(); ++i) EXPECT_NEAR(y[i], expected[i], 1e-5) << i;
}

// Light along the normal, view along x: the half vector is (1, 0, 1) / sqrt 2; the inputs are
// normalised first.
TEST(NeuralNetwork, DirectionEncodingIsLightViewAndHalfVector) {
  float out[detail::kDirectionInputs];
  detail::encode_directions({0, 0, 2}, {3, 0, 0}, out);
  const float r = float(std::numbers::sqrt2 / 2);
  const float expected[] = {0, 0, 1, 1, 0, 0, r, 0, r};
  for (std::size_t i = 0; i < detail::kDirectionInputs; ++i)
    EXPECT_NEAR(out[i], expected[i], 1e-7) << i;
}

// He initialisation: the same vector for a seed, another for another seed, every weight within
// its layer's bound and the bound nearly reached, the biases zero.
TEST(NeuralNetwork, InitialParametersFollowTheSeed) {
  const NetworkShape shape{.latent = 8, .width = 32, .depth = 2};
  const std::vector<float> a = detail::initial_parameters(shape, 7);
  EXPECT_EQ(a, detail::initial_parameters(shape, 7));
  EXPECT_NE(a, detail::initial_parameters(shape, 8));
  for (const detail::LayerLayout& at : detail::layer_layout(shape)) {
    const bool hidden = at.outputs != detail::kNetworkOutputs;
    const double slope = double(detail::kLeakySlope);
    const double gain = hidden ? std::sqrt(2.0 / (1.0 + slope * slope)) : 1.0;
    const double bound = gain * std::sqrt(3.0 / double(at.inputs));
    double largest = 0.0;
    for (std::size_t i = at.weights; i < at.biases; ++i)
      largest = std::max(largest, double(std::abs(a[i])));
    EXPECT_LE(largest, bound);
    EXPECT_GT(largest, 0.9 * bound);
    for (std::size_t i = at.biases; i < at.biases + at.outputs; ++i) EXPECT_EQ(a[i], 0.0f);
  }
}

TEST(NeuralNetwork, ShapeOutsideItsRangesIsRefused) {
  EXPECT_NO_THROW(detail::check_network_shape({.latent = 8, .width = 32, .depth = 2}));
  try {
    detail::initial_parameters({.latent = 0, .width = 32, .depth = 2}, 1);
    FAIL() << "a latent of 0 values was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), Error::Kind::kArgument);
    EXPECT_NE(std::string(e.what()).find("latent size"), std::string::npos) << e.what();
  }
  EXPECT_THROW(detail::check_network_shape({.latent = 8, .width = 0, .depth = 2}), Error);
  EXPECT_THROW(detail::check_network_shape({.latent = 8, .width = 32, .depth = 17}), Error);
}

// A teacher network and the samples of its outputs that a student of its shape learns.
struct Teacher {
  NetworkShape shape{.latent = 8, .width = 32, .depth = 2};
  std::vector<float> theta, x, targets;
  double spread = 0.0;  // the targets' standard deviation
  Teacher() : theta(detail::initial_parameters(shape, 21)), x(random_inputs(shape, 1024, 22)) {
    const detail::LayerLayout out = detail::layer_layout(shape).back();
    for (std::size_t i = 0; i < out.outputs; ++i) theta[out.biases + i] = 0.5f;
    targets = outputs_of<float>(shape, theta, x);
    double mean = 0.0;
    for (float t : targets) mean += t / double(targets.size());
    for (float t : targets) spread += (t - mean) * (t - mean) / double(targets.size());
    spread = std::sqrt(spread);
  }
  // The student's RMSE over the samples, relative to the targets' spread.
  double relative_rmse(std::span<const float> student) const {
    const double e = detail::squared_error_gradient(shape, student, x, targets, 1).error;
    return std::sqrt(e / double(targets.size())) / spread;
  }
  // The student after `steps` full-batch Adam steps from `start`, the rate falling
  // geometrically from `rate` to `rate` x `fall`.
  std::vector<float> student(std::vector<float> start, int steps, double rate, double fall) const {
    Adam adam(std::move(start));
    for (int k = 0; k < steps; ++k) {
      const detail::SquaredErrorGradient g =
          detail::squared_error_gradient(shape, adam.theta, x, targets, 1);
      adam.step(g.parameters, float(rate * std::pow(fall, double(k) / steps)));
    }
    return adam.theta;
  }
};

// A student of the teacher's shape (latent 8, two hidden layers of 32) learns the teacher's
// outputs on 1024 samples by full-batch Adam. Started from the teacher's parameters moved a fifth
// of the way to another seed's (an RMSE of 47% of the targets' spread), 2000 steps at rate 1e-3
// bring it below 1.5% (0.93% measured). From another seed's parameters alone (136%) the same
// number of steps bring it below 20% (14% measured), not lower: a student of its teacher's size
// meets spurious minima and long plateaus from most starts (Safran & Shamir 2018, "Spurious local
// minima are common in two-layer ReLU neural networks").
TEST(NeuralNetwork, StudentLearnsTeacherOfItsShape) {
  const Teacher teacher;
  const std::vector<float> other = detail::initial_parameters(teacher.shape, 23);
  std::vector<float> near(other.size());
  for (std::size_t i = 0; i < near.size(); ++i) near[i] = 0.8f * teacher.theta[i] + 0.2f * other[i];
  EXPECT_GT(teacher.relative_rmse(near), 0.4);
  EXPECT_LT(teacher.relative_rmse(teacher.student(near, 2000, 1e-3, 1.0)), 0.015);
  EXPECT_GT(teacher.relative_rmse(other), 1.0);
  EXPECT_LT(teacher.relative_rmse(teacher.student(other, 2000, 3e-3, 0.3)), 0.2);
}

// The batched gradient on 1, 2 and 3 threads: equal bit for bit (33000 samples: 65 chunks of
// 512, the last one short, more than are held at once), and equal to one backward pass over the
// whole batch to float's precision.
TEST(NeuralNetwork, BatchedGradientIsTheSameOnAnyNumberOfThreads) {
  const NetworkShape shape{.latent = 8, .width = 32, .depth = 2};
  const std::size_t samples = 33000, n = detail::input_size(shape);
  const std::vector<float> theta = detail::initial_parameters(shape, 31);
  const std::vector<float> x = random_inputs(shape, samples, 32);
  const std::vector<float> targets = uniform_values<float>(samples * 3, 33, 0, 1);
  const detail::SquaredErrorGradient one =
      detail::squared_error_gradient(shape, theta, x, targets, 1);
  for (int threads : {2, 3}) {
    const detail::SquaredErrorGradient more =
        detail::squared_error_gradient(shape, theta, x, targets, threads);
    EXPECT_EQ(std::memcmp(&one.error, &more.error, sizeof(double)), 0) << threads << " threads";
    ASSERT_EQ(one.parameters.size(), more.parameters.size());
    ASSERT_EQ(one.latents.size(), more.latents.size());
    EXPECT_EQ(std::memcmp(one.parameters.data(), more.parameters.data(),
                          one.parameters.size() * sizeof(float)),
              0)
        << threads << " threads";
    EXPECT_EQ(
        std::memcmp(one.latents.data(), more.latents.data(), one.latents.size() * sizeof(float)), 0)
        << threads << " threads";
  }
  // The same gradient by one backward pass, dE/dy = 2 (y - target).
  std::vector<float> y = outputs_of<float>(shape, theta, x), dy(y.size());
  double error = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    dy[i] = 2.0f * (y[i] - targets[i]);
    error += double(y[i] - targets[i]) * double(y[i] - targets[i]);
  }
  std::vector<float> g(theta.size()), gx(x.size());
  detail::backward(shape, theta, x, dy, g, gx);
  EXPECT_NEAR(one.error, error, 1e-5 * error);
  double largest = 0.0;
  for (float v : g) largest = std::max(largest, double(std::abs(v)));
  EXPECT_GT(largest, 1.0);
  for (std::size_t i = 0; i < g.size(); ++i)
    EXPECT_NEAR(one.parameters[i], g[i], 1e-4 * largest) << "parameter " << i;
  double steepest = 0.0;
  for (float v : gx) steepest = std::max(steepest, double(std::abs(v)));
  for (std::size_t s = 0; s < samples; ++s)
    for (std::size_t i = 0; i < shape.latent; ++i)
      ASSERT_NEAR(one.latents[s * shape.latent + i], gx[s * n + i], 1e-5 * steepest)
          << "sample " << s;
}

// Adam's first two steps by hand (Kingma & Ba 2015, Algorithm 1). Parameter 0 from 1 at rate
// 0.1, gradients 0.5 then -0.25:
//   step 1: m = 0.05, v = 0.00025, m^ = 0.5, v^ = 0.25: theta = 1 - 0.1 (0.5 / 0.5) = 0.9
//   step 2: m = 0.045 - 0.025 = 0.02, v = 0.00024975 + 0.0000625 = 0.00031225,
//           m^ = 0.02 / 0.19, v^ = 0.00031225 / 0.001999:
//           theta = 0.9 - 0.1 (0.02 / 0.19) / sqrt(0.00031225 / 0.001999) = 0.87336629603396
// Parameter 1 from -2 at rate 0.01 (its own rate), gradients -4 then 2 (the same ratios):
//   -2 + 0.01 = -1.99, then -1.99 + 0.01 (0.026633703966040) = -1.98733662960340.
TEST(Adam, FirstTwoStepsAsComputedByHand) {
  Adam adam(std::vector<double>{1.0, -2.0});
  const auto rate_of = [](std::size_t i) { return i == 0 ? 0.1 : 0.01; };
  adam.step(std::vector<double>{0.5, -4.0}, rate_of);
  EXPECT_NEAR(adam.theta[0], 0.9, 1e-15);
  EXPECT_NEAR(adam.theta[1], -1.99, 1e-15);
  EXPECT_NEAR(adam.m1[0], 0.05, 1e-17);
  EXPECT_NEAR(adam.m2[0], 0.00025, 1e-18);
  adam.step(std::vector<double>{-0.25, 2.0}, rate_of);
  EXPECT_EQ(adam.t, 2);
  EXPECT_NEAR(adam.theta[0], 0.87336629603396, 1e-13);
  EXPECT_NEAR(adam.theta[1], -1.98733662960340, 1e-13);

  // In float, one rate for every parameter, the same steps to float's precision.
  Adam<float> single(std::vector<float>{1.0f});
  single.step(std::vector<float>{0.5f}, 0.1f);
  single.step(std::vector<float>{-0.25f}, 0.1f);
  EXPECT_NEAR(single.theta[0], 0.87336629603396, 1e-6);
}

// A parameter whose gradient is zero at every step stays where it is (0 / (0 + epsilon)).
TEST(Adam, ZeroGradientLeavesTheParameter) {
  Adam<float> adam(std::vector<float>{0.25f, 1.0f});
  for (int k = 0; k < 3; ++k) adam.step(std::vector<float>{0.0f, 1.0f}, 0.5f);
  EXPECT_EQ(adam.theta[0], 0.25f);
  EXPECT_NEAR(adam.theta[1], -0.5, 1e-6);
}

}  // namespace
}  // namespace btfgmm
