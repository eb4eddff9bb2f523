// The neural BTF's fit (Rainer, Jakob, Ghosh & Weyrich 2019, Sec. 4: the decoder's network and
// the texels' latents trained together by Adam on minibatches of (texel, light, view) samples
// against the measured RGB), with the held-out validation and stopping rule of the mixture's
// refinement (model/refine.hpp): the lowest held-out error kept, the rate halved when it stops
// falling, bounded in epochs, never in time, so that the same data, settings and seed give the
// same model on any number of threads.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "btfgmm/methods/neural_btf_checkpoint.hpp"
#include "btfgmm/model/refine.hpp"
#include "core/adam.hpp"
#include "core/random.hpp"
#include "methods/factors.hpp"
#include "methods/neural_btf_internal.hpp"
#include "methods/neural_network_gpu.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm {

std::size_t detail::neural_batch_size(std::size_t training) {
  return std::clamp<std::size_t>(training / 64, 128, 4096);
}

std::size_t detail::neural_epoch_steps(std::size_t training) {
  const std::size_t batch = neural_batch_size(training);
  return std::max<std::size_t>((training + batch - 1) / batch, 1);
}

// 30 epochs where they take at most kNeuralDefaultSteps steps, 6 where those take at most
// kNeuralMostSteps, else as many as kNeuralMostSteps allow, and at least one.
int detail::neural_default_epochs(std::size_t training) {
  const std::size_t steps = neural_epoch_steps(training);
  const std::size_t within_default =
      std::min<std::size_t>(kNeuralDefaultSteps / steps, std::size_t(kNeuralDefaultEpochs));
  const std::size_t least =
      std::min<std::size_t>(kNeuralMostSteps / steps, std::size_t(kNeuralLeastEpochs));
  return int(std::max<std::size_t>({within_default, least, 1}));
}

namespace {

constexpr std::string_view kMethod = "neural";

// Adam's rates (Kingma & Ba 2015's alpha) for the network's parameters and for the latents,
// warmed up over the first kWarmUpSteps steps; the validation's blocks of samples.
constexpr float kNetworkRate = 5e-3f;
constexpr float kLatentRate = 1e-2f;
constexpr int kWarmUpSteps = 20;
constexpr std::size_t kValidationBlock = 4096;
// The stopping rule (GradientConfig's): the rate halved when the held-out error has not
// fallen by kMinGain (relative) over kPatience validations, a quarter epoch apart; the steps
// end after kPlateaus halvings.
constexpr int kPatience = 4, kPlateaus = 3;
constexpr double kMinGain = 1e-3;

// The fit's samples: sample i = pair j * pixels + texel p, the tile's own order.
struct Samples {
  NeuralShape shape;
  std::size_t pixels = 0, pairs = 0;
  std::vector<float> directions;  // pairs x kDirectionInputs (encode_directions)
  std::vector<float> targets;     // the tile's values / scale, samples x 3
  std::vector<std::uint32_t> training, validation;
  float scale = 1.0f;
};

// A shape option: `fallback` when 0, else within 1..max; Error(kArgument) naming it.
std::size_t shape_setting(std::size_t given, std::size_t fallback, std::size_t max,
                          std::string_view field, std::string_view what) {
  if (given == 0) return fallback;
  if (given > max)
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: {} takes 1..{} {}", option_value(field, std::to_string(given)),
                            kMethod, max, what));
  return given;
}

NeuralShape shape_of(const FitOptions& s) {
  detail::refuse_clusters(s, kMethod);
  return {.latent = shape_setting(s.components, kNeuralDefaultLatent, detail::kMaxLatent,
                                  "components", "latent values per texel"),
          .width = shape_setting(s.width, kNeuralDefaultWidth, detail::kMaxWidth, "width",
                                 "units per hidden layer"),
          .depth = shape_setting(s.depth, kNeuralDefaultDepth, detail::kMaxDepth, "depth",
                                 "hidden layers")};
}

// The data value of a network output of 1: the tile's RMS value (1 for a tile of zeros), so
// that the network's targets are about 1.
float output_scale(const Btf& tile) {
  double sum = 0.0;
  for (const float v : tile.data()) sum += double(v) * double(v);
  const double rms = std::sqrt(sum / double(std::max<std::size_t>(tile.data().size(), 1)));
  return rms > 1e-6 ? float(rms) : 1.0f;
}

// The samples, split as the mixture's refinement splits them (validation_sample).
Samples samples_of(const Btf& tile, const NeuralShape& shape) {
  Samples s;
  s.shape = shape;
  s.pixels = std::size_t(tile.width()) * std::size_t(tile.height());
  s.pairs = tile.image_count();
  s.scale = output_scale(tile);
  s.directions.resize(s.pairs * detail::kDirectionInputs);
  for (std::size_t l = 0; l < tile.lights().size(); ++l)
    for (std::size_t v = 0; v < tile.views().size(); ++v)
      detail::encode_directions(to_vector(tile.lights()[l]), to_vector(tile.views()[v]),
                                std::span(s.directions)
                                    .subspan(tile.image_index(l, v) * detail::kDirectionInputs,
                                             detail::kDirectionInputs));
  s.targets.resize(tile.data().size());
  for (std::size_t i = 0; i < s.targets.size(); ++i) s.targets[i] = tile.data()[i] / s.scale;
  for (std::size_t j = 0; j < s.pairs; ++j)
    for (std::size_t p = 0; p < s.pixels; ++p) {
      const auto i = std::uint32_t(j * s.pixels + p);
      (validation_sample(p, j, s.pairs) ? s.validation : s.training).push_back(i);
    }
  // A tile too small to hold out a sample (or to train on one) validates on what it has.
  if (s.validation.empty()) s.validation = s.training;
  if (s.training.empty()) s.training = s.validation;
  return s;
}

// The network's inputs and targets of the samples `ids`: each texel's latent from `latents`
// (pixels x L), then its pair's directions.
void gather(const Samples& s, std::span<const float> latents, std::span<const std::uint32_t> ids,
            std::vector<float>& inputs, std::vector<float>& targets) {
  const std::size_t L = s.shape.latent, n = L + detail::kDirectionInputs;
  inputs.resize(ids.size() * n);
  targets.resize(ids.size() * 3);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const std::size_t p = ids[k] % s.pixels, j = ids[k] / s.pixels;
    std::copy_n(&latents[p * L], L, &inputs[k * n]);
    std::copy_n(&s.directions[j * detail::kDirectionInputs], detail::kDirectionInputs,
                &inputs[k * n + L]);
    std::copy_n(&s.targets[std::size_t(ids[k]) * 3], 3, &targets[k * 3]);
  }
}

// theta = the network's parameters, then the latents (pixels x L): Adam's one vector.
std::span<const float> network_of(const Samples& s, std::span<const float> theta) {
  return theta.first(detail::parameter_count(detail::network_shape(s.shape)));
}
std::span<const float> latents_of(const Samples& s, std::span<const float> theta) {
  return theta.subspan(detail::parameter_count(detail::network_shape(s.shape)));
}

// Where the network's passes run: on the CPU's threads, or on a compute device (docs/GPU.md,
// "The neural fit"; null: the CPU).
struct NetworkPasses {
  int threads = 0;
  std::unique_ptr<detail::NetworkGradientPass> device;
};

// The held-out samples' squared error on the device, block after block, added in order.
double device_validation_error(const Samples& s, std::span<const float> theta,
                               detail::NetworkGradientPass& device) {
  device.set_parameters(network_of(s, theta));
  std::vector<float> inputs, targets;
  double error = 0.0;
  for (std::size_t first = 0; first < s.validation.size(); first += kValidationBlock) {
    gather(s, latents_of(s, theta),
           std::span(s.validation)
               .subspan(first, std::min(kValidationBlock, s.validation.size() - first)),
           inputs, targets);
    error += device.squared_error(inputs, targets);
  }
  return error;
}

// The squared error over the held-out samples, in blocks of kValidationBlock (each block on
// one thread, their errors added in block order: the same sum on any number of threads).
double validation_error(const Samples& s, std::span<const float> theta,
                        const NetworkPasses& passes) {
  if (passes.device) return device_validation_error(s, theta, *passes.device);
  const std::size_t blocks = (s.validation.size() + kValidationBlock - 1) / kValidationBlock;
  std::vector<double> errors(blocks, 0.0);
#pragma omp parallel
  {
    omp_set_num_threads(1);
    std::vector<float> inputs, targets, out;
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t b = 0; b < std::ptrdiff_t(blocks); ++b) {
      const std::size_t first = std::size_t(b) * kValidationBlock;
      const auto ids = std::span(s.validation)
                           .subspan(first, std::min(kValidationBlock, s.validation.size() - first));
      gather(s, latents_of(s, theta), ids, inputs, targets);
      out.resize(targets.size());
      detail::forward(detail::network_shape(s.shape), network_of(s, theta), inputs, out);
      for (std::size_t i = 0; i < out.size(); ++i)
        errors[std::size_t(b)] += double(out[i] - targets[i]) * double(out[i] - targets[i]);
    }
  }
  return std::accumulate(errors.begin(), errors.end(), 0.0);
}

// The held-out RMSE in the data's levels.
double validation_rmse(const Samples& s, std::span<const float> theta,
                       const NetworkPasses& passes) {
  const double n = double(std::max<std::size_t>(s.validation.size(), 1)) * 3.0;
  return std::sqrt(validation_error(s, theta, passes) / n) * double(s.scale);
}

// The start: the network's initial parameters (He et al. 2015), the latents uniform in
// [-0.5, 0.5], both from the seed.
std::vector<float> initial_theta(const Samples& s, std::uint64_t seed) {
  std::vector<float> theta = detail::initial_parameters(detail::network_shape(s.shape), seed);
  detail::SplitMix64 draw(seed ^ 0x6c61746e74ULL);
  for (std::size_t i = 0; i < s.pixels * s.shape.latent; ++i)
    theta.push_back(float(draw.uniform(-0.5, 0.5)));
  return theta;
}

std::size_t batch_size(const Samples& s) {
  return detail::neural_batch_size(s.training.size());
}

// The squared error's gradient over a batch (detail::squared_error_gradient's), where the
// passes run.
detail::SquaredErrorGradient batch_gradient(const Samples& s, std::span<const float> theta,
                                            std::span<const float> inputs,
                                            std::span<const float> targets,
                                            const NetworkPasses& passes) {
  if (!passes.device)
    return detail::squared_error_gradient(detail::network_shape(s.shape), network_of(s, theta),
                                          inputs, targets, passes.threads);
  passes.device->set_parameters(network_of(s, theta));
  return passes.device->gradient(inputs, targets);
}

// One Adam step on the minibatch `ids`: the squared error's gradient (the network's, and each
// texel's latent's summed over its samples in batch order), divided by the batch's size.
void adam_step(const Samples& s, std::span<const std::uint32_t> ids, double rate_scale,
               const NetworkPasses& passes, Adam<float>& adam) {
  std::vector<float> inputs, targets;
  gather(s, latents_of(s, adam.theta), ids, inputs, targets);
  const detail::SquaredErrorGradient g = batch_gradient(s, adam.theta, inputs, targets, passes);
  const std::size_t P = g.parameters.size(), L = s.shape.latent;
  std::vector<float> grad(adam.theta.size(), 0.0f);
  std::copy(g.parameters.begin(), g.parameters.end(), grad.begin());
  for (std::size_t k = 0; k < ids.size(); ++k)
    for (std::size_t j = 0; j < L; ++j)
      grad[P + (ids[k] % s.pixels) * L + j] += g.latents[k * L + j];
  const float inverse = 1.0f / float(ids.size());
  for (float& v : grad) v *= inverse;
  const double warm_up = std::min(1.0, double(adam.t + 1) / kWarmUpSteps);
  const float network_rate = float(kNetworkRate * warm_up * rate_scale),
              latent_rate = float(kLatentRate * warm_up * rate_scale);
  adam.step(grad, [&](std::size_t i) { return i < P ? network_rate : latent_rate; });
}

// The stopping rule on the held-out error, as the mixture's refinement's (refine_gradient.cpp).
struct Convergence {
  double best = INFINITY, reference = INFINITY, rate_scale = 1.0;
  int since_gain = 0, plateaus = 0;
  bool converged(double e) {
    best = std::min(best, e);
    if (e < reference * (1.0 - kMinGain)) {
      reference = e;
      since_gain = 0;
      return false;
    }
    if (++since_gain < kPatience) return false;
    since_gain = 0;
    reference = best;
    rate_scale *= 0.5;
    return ++plateaus >= kPlateaus;
  }
};

// The training samples in an order drawn from the seed and the epoch (Fisher-Yates).
void shuffle_for_epoch(std::vector<std::uint32_t>& ids, std::uint64_t seed, int epoch) {
  detail::SplitMix64 draw(detail::mix64(seed + 0x9e37ULL * std::uint64_t(epoch + 1)));
  for (std::size_t i = ids.size(); i > 1; --i)
    std::swap(ids[i - 1], ids[std::size_t(draw.next() % i)]);
}

// The parameters of the lowest held-out error met, and that error (levels); where a stop was
// asked for, the epoch it came in.
struct Best {
  std::vector<float> theta;
  double rmse = INFINITY;
  int stopped_in_epoch = 0;
};

bool stop_asked(const FitOptions& o) {
  return o.stop && o.stop->load();
}

// The epochs a fit takes at most: `iterations` where given, else the default's.
int most_epochs(const Samples& s, const FitOptions& o) {
  return o.iterations > 0 ? o.iterations : detail::neural_default_epochs(s.training.size());
}

// Where a fit stands (NeuralFitState, methods/neural_btf_checkpoint.hpp): Adam, the best
// parameters met, the stopping rule, the next step.
struct Training {
  Adam<float> adam;
  Best best;
  Convergence rule;
  int epoch = 0;
  std::size_t steps_done = 0;
  bool validation_due = false;
};

Training started(const Samples& s, const FitOptions& o, const NetworkPasses& passes) {
  Adam<float> adam(initial_theta(s, o.seed));
  Best best{.theta = adam.theta, .rmse = validation_rmse(s, adam.theta, passes)};
  return {.adam = std::move(adam), .best = std::move(best), .rule = {}};
}

NeuralFitState state_of(const Training& t) {
  return {.epoch = t.epoch,
          .steps_done = t.steps_done,
          .validation_due = t.validation_due,
          .theta = t.adam.theta,
          .first_moment = t.adam.m1,
          .second_moment = t.adam.m2,
          .adam_steps = t.adam.t,
          .best_theta = t.best.theta,
          .best_rmse = t.best.rmse,
          .rule_best = t.rule.best,
          .rule_reference = t.rule.reference,
          .rate_scale = t.rule.rate_scale,
          .since_gain = t.rule.since_gain,
          .plateaus = t.rule.plateaus};
}

// The fit a checkpoint's state holds; Error(kFormat) where its sizes are not this shape's on
// this tile, or it stands past the epochs or steps the fit takes.
Training resumed(const Samples& s, const NeuralFitState& k, int epochs, std::size_t steps) {
  const std::size_t n =
      detail::parameter_count(detail::network_shape(s.shape)) + s.pixels * s.shape.latent;
  if (k.theta.size() != n || k.first_moment.size() != n || k.second_moment.size() != n ||
      k.best_theta.size() != n)
    throw Error(Error::Kind::kFormat,
                fmt::format("the checkpoint's state holds {} parameters where the network and "
                            "latents of this tile hold {}; start the fit again without {}",
                            k.theta.size(), n, option_name("resume")));
  if (k.epoch < 0 || k.epoch > epochs || k.steps_done > steps ||
      std::int64_t(k.adam_steps) !=
          std::int64_t(k.epoch) * std::int64_t(steps) + std::int64_t(k.steps_done) ||
      (k.validation_due && k.steps_done == 0))
    throw Error(Error::Kind::kFormat,
                fmt::format("the checkpoint stands at step {} of epoch {} after {} Adam steps, "
                            "outside the fit's {} epochs of {} steps; start the fit again "
                            "without {}",
                            k.steps_done, std::int64_t(k.epoch) + 1, k.adam_steps, epochs, steps,
                            option_name("resume")));
  Adam<float> adam(k.theta);
  adam.m1 = k.first_moment;
  adam.m2 = k.second_moment;
  adam.t = k.adam_steps;
  return {.adam = std::move(adam),
          .best = {.theta = k.best_theta, .rmse = k.best_rmse},
          .rule = {.best = k.rule_best,
                   .reference = k.rule_reference,
                   .rate_scale = k.rate_scale,
                   .since_gain = k.since_gain,
                   .plateaus = k.plateaus},
          .epoch = k.epoch,
          .steps_done = k.steps_done,
          .validation_due = k.validation_due};
}

// The epochs of Adam steps, validated every quarter epoch; the best parameters met. The state
// is saved after every `c.every_epochs` epochs and when stopped; a fit from `c.resume` goes on
// as the fit that saved it would have.
Best train(const Samples& s, const FitOptions& o, const NetworkPasses& passes, int epochs,
           const NeuralCheckpointing& c) {
  std::vector<std::uint32_t> order = s.training;
  const std::size_t batch = batch_size(s), steps = detail::neural_epoch_steps(order.size());
  const std::size_t every = std::max<std::size_t>(1, steps / 4);
  Training t = c.resume ? resumed(s, *c.resume, epochs, steps) : started(s, o, passes);
  for (int e = 0; e < t.epoch; ++e) shuffle_for_epoch(order, o.seed, e);  // each shuffles the last
  for (; t.epoch < epochs; ++t.epoch, t.steps_done = 0) {
    shuffle_for_epoch(order, o.seed, t.epoch);
    for (std::size_t k = t.validation_due ? t.steps_done - 1 : t.steps_done; k < steps; ++k) {
      if (!t.validation_due) {
        const std::size_t first = k * batch;
        adam_step(s, std::span(order).subspan(first, std::min(batch, order.size() - first)),
                  t.rule.rate_scale, passes, t.adam);
        t.steps_done = k + 1;
        if (stop_asked(o)) {  // the best met is kept: the file says the fit was stopped
          t.validation_due = true;
          if (c.save) c.save(state_of(t));
          t.best.stopped_in_epoch = t.epoch + 1;
          return t.best;
        }
      }
      t.validation_due = false;
      if ((k + 1) % every != 0 && k + 1 != steps) continue;
      const double rmse = validation_rmse(s, t.adam.theta, passes);
      if (rmse < t.best.rmse) t.best = {.theta = t.adam.theta, .rmse = rmse};
      detail::report(o, (double(t.epoch) + double(k + 1) / double(steps)) / double(epochs),
                     fmt::format("epoch {} of {}: held-out RMSE {:.3f} (best {:.3f})", t.epoch + 1,
                                 epochs, rmse, t.best.rmse));
      if (t.rule.converged(rmse)) return t.best;
    }
    if (c.save && c.every_epochs > 0 && (t.epoch + 1) % c.every_epochs == 0 &&
        t.epoch + 1 < epochs) {
      NeuralFitState next = state_of(t);  // the state before the next epoch's first step
      ++next.epoch;
      next.steps_done = 0;
      c.save(next);
    }
  }
  return t.best;
}

// The passes on `device` (null: the CPU's `threads`), for batches and validation blocks.
NetworkPasses passes_on(ComputeDevice* device, const Samples& s, const FitOptions& o) {
  NetworkPasses passes{.threads = o.threads, .device = nullptr};
  if (device)
    passes.device = std::make_unique<detail::NetworkGradientPass>(
        *device, detail::network_shape(s.shape), std::max(batch_size(s), kValidationBlock));
  return passes;
}

void check_tile(const Btf& tile) {
  if (tile.data().empty())
    throw Error(Error::Kind::kArgument, "the neural BTF needs a tile with at least one image");
  if (tile.data().size() / 3 > std::numeric_limits<std::uint32_t>::max())
    throw Error(Error::Kind::kArgument,
                fmt::format("the tile's {} samples are too many for a neural fit; cut a smaller "
                            "tile ({})",
                            tile.data().size() / 3, option_name("tile")));
}

}  // namespace

std::unique_ptr<Representation> fit_neural_btf(const Btf& tile, const FitOptions& o) {
  return fit_neural_btf(tile, o, NeuralCheckpointing{});
}

std::unique_ptr<Representation> fit_neural_btf(const Btf& tile, const FitOptions& o,
                                               const NeuralCheckpointing& checkpointing) {
  const NeuralShape shape = shape_of(o);
  check_tile(tile);
  const FactorEncoding e = stored_encoding(o);
  const detail::ThreadScope threads(o.threads);
  detail::report(o, 0.0, "samples and held-out set");
  const Samples s = samples_of(tile, shape);
  const int epochs = most_epochs(s, o);
  const std::shared_ptr<ComputeDevice> device = open_compute_device(fit_device(o));
  const NetworkPasses passes = passes_on(device.get(), s, o);
  Best best = train(s, o, passes, epochs, checkpointing);
  if (best.stopped_in_epoch == 0)
    detail::report(o, 1.0, fmt::format("done: held-out RMSE {:.3f}", best.rmse));
  // Stored as the file stores them: the model in memory evaluates as the one read back.
  std::vector<float> theta(network_of(s, best.theta).begin(), network_of(s, best.theta).end());
  detail::quantise_factors(theta, theta.size(), FactorEncoding::kF16);
  std::vector<float> rows = detail::latent_rows(latents_of(s, best.theta), shape.latent);
  detail::quantise_factors(rows, s.pixels, e);
  auto model =
      std::make_unique<NeuralBtf>(ModelFrame::of(tile), shape, e, s.scale,
                                  detail::latent_columns(rows, shape.latent), std::move(theta));
  Provenance p;
  if (device) p.fit.settings.emplace_back(kDeviceSetting, device->info().description());
  if (best.stopped_in_epoch > 0)
    p.fit.settings.emplace_back(
        kStoppedSetting, fmt::format("in epoch {} of {}: the lowest held-out error met, {:.3f}",
                                     best.stopped_in_epoch, epochs, best.rmse));
  if (!p.fit.settings.empty()) model->set_provenance(std::move(p));
  return model;
}

}  // namespace btfgmm
