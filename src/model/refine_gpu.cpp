// The fit for the prediction's passes on a compute device (refine_gpu.hpp). Per pass:
//   components     per component its parameters (5 vec4), uploaded;
//   tables         the parts of t_m (exponent_parts, Eq. 9-10) both ways, on the device;
//   errors         per slot of the selection its weights' largest exponent and normaliser,
//                  its error and e . yhat; per workgroup of one light the squared errors;
//   statistics     per (row, light, chunk of pixels, component) the gradient's 12 sums;
//   light sums     each light's chunks added in chunk order, then (one process) each row's
//                  lights in light order, as fold_over_processes adds them;
// then the light's angles' terms added on the host in double: the same result for any
// number of threads and, for a given device, run after run.
#include "model/refine_gpu.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "gpu/device_check.hpp"
#include "model/conditional.hpp"
#include "model/gpu_passes.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::uint32_t kErrorGroup = 256;      // refine_errors.comp's local size
constexpr std::uint32_t kTableGroup = 256;      // refine_tables.comp's local size
constexpr std::size_t kBlock = 64;              // refine_normal.comp's block of G
constexpr std::uint32_t kColumnsPerGroup = 64;  // refine_statistics.comp's columns a workgroup
constexpr std::uint32_t kRows = 12;             // refine_statistics.comp's sums per column

struct TablesPush {
  std::uint32_t components, pixels, lights, views, width;
  float period_x, period_y;
};
struct ErrorsPush {
  std::uint32_t components, pixels, lights, views, held, first_light, modulus, residue, part, slots,
      groups_per_light;
};
struct StatisticsPush {
  std::uint32_t components, pixels, views, held, first_light, width, chunks, slots;
  float period_x, period_y;
};
struct NormalPush {
  std::uint32_t components, pixels, views, held, first_light, slots, blocks;
};

std::uint32_t part_code(Selection::Part part) {
  return part == Selection::Part::kAll ? 0 : part == Selection::Part::kTraining ? 1 : 2;
}

// d t / d mu and d t / d s of an angle: the term -s/2 - d^2 / (2 sigma^2) of Eq. (10), as
// GradientPass adds the lights' (refine_gradient.cpp).
void add_angle_gradient(double g, double x, std::size_t k, std::size_t n, const ProductMixture& mix,
                        PredictionGradient& out) {
  const double var = mix.var[k][n];
  const double d = x - mix.mean[k][n];
  out.mean[k][n] += g * d / var;
  out.log_var[k][n] += 0.5 * g * (d * d / var - 1.0);
}

}  // namespace

struct GpuPredictionPass::State {
  ComputeDevice& device;
  const SampleSet& s;
  std::size_t m;
  Periods periods;
  std::shared_ptr<GpuKernel> tables, errors, statistics, normal, light_sums;
  std::shared_ptr<GpuBuffer> residual, held_bits, light_ab, view_ab, slots_buffer, group_errors;
  std::shared_ptr<GpuBuffer> parameters, pixel_t, light_t, view_t, pixel_r, light_r, view_r,
      chunk_sums, sums, totals, gram_blocks, rhs_blocks;

  State(ComputeDevice& d, const SampleSet& samples, std::size_t components)
      : device(d),
        s(samples),
        m(components),
        periods(variable_periods({double(samples.width), double(samples.height)})) {}

  std::uint32_t groups_per_light(std::size_t per_pixel) const {
    return std::uint32_t((s.pixels() * per_pixel + kErrorGroup - 1) / kErrorGroup);
  }
  void upload_samples();
  void make_tables(const ProductMixture& mix);
  std::vector<double> normal_sums(const ProductMixture& mix, const Selection& training);
  std::uint32_t run_errors(const Selection& selection);
  std::vector<double> light_errors(std::size_t per_pixel);
  void sum(GpuBuffer& from, GpuBuffer& to, std::size_t per_chunk, std::size_t chunks,
           std::size_t groups) {
    sum_chunks(device, *light_sums, from, to, per_chunk, chunks, groups);
  }
  std::vector<double> totals_of(std::uint32_t chunks);
  PredictionGradient result(const ProductMixture& mix, const std::vector<double>& total) const;
};

double GpuPredictionPass::device_bytes(const SampleSet& s, std::size_t components) {
  const double n = double(s.held_size()), m = double(components);
  const double held = double(s.held_lights()), chunks = gpu_chunks(s.pixels());
  const double tables = 8.0 * m * double(s.pixels() + s.lights + s.views) + 80.0 * m;
  const double blocks = std::ceil(m / double(kBlock)) * double(kBlock);
  return n * (16.0 + 32.0 + 0.125) + tables + 8.0 * kRows * m * (held * (chunks + 1) + 1) +
         8.0 * blocks * (blocks + 3) +
         16.0 * held * std::ceil(double(s.pixels() * s.views) / kErrorGroup);
}

GpuPredictionPass::GpuPredictionPass(ComputeDevice& device, const SampleSet& s,
                                     std::size_t components)
    : state_(std::make_unique<State>(device, s, components)) {
  const double m = double(components), held = double(s.held_lights());
  const double blocks = std::ceil(m / double(kBlock)) * double(kBlock);
  const double largest =
      std::max({32.0 * double(s.held_size()), 4.0 * double(s.pixels()) * m,
                8.0 * held * double(gpu_chunks(s.pixels())) * kRows * m, 8.0 * blocks * blocks});
  check_device_holds(device.info(), device_bytes(s, components), largest,
                     "the refinement's " + std::to_string(s.held_size()) + " samples");
  check_loop_nest(device.info(), statistics_iterations(s.pixels(), s.views),
                  "the refinement's passes");
  State& g = *state_;
  g.tables = device.kernel("refine_tables.spv", 9, sizeof(TablesPush));
  g.errors = device.kernel("refine_errors.spv", 8, sizeof(ErrorsPush));
  g.statistics = device.kernel("refine_statistics.spv", 7, sizeof(StatisticsPush));
  g.normal = device.kernel("refine_normal.spv", 7, sizeof(NormalPush));
  g.light_sums = chunk_sums_kernel(device);
  g.upload_samples();
}

GpuPredictionPass::~GpuPredictionPass() = default;

// The residual colours (r, g, b, 0) and the held-out bits, light-major (held light, pixel,
// view), a light at a time; the view angles; room for the slots and the tables.
void GpuPredictionPass::State::upload_samples() {
  const std::size_t per_light = s.pixels() * s.views, held = s.held_lights();
  const std::size_t pairs = s.lights * s.views;
  residual = device.buffer(s.held_size() * 4 * sizeof(float));
  std::vector<float> light(per_light * 4, 0.0f), block(s.views * 3);
  std::vector<std::uint32_t> bits((s.held_size() + 31) / 32, 0);
  for (std::size_t lh = 0; lh < held; ++lh) {
    const std::size_t l = s.first_light + lh;
    for (std::size_t p = 0; p < s.pixels(); ++p) {
      s.block_residuals(p, l, block.data());
      for (std::size_t v = 0; v < s.views; ++v) {
        std::copy_n(&block[3 * v], 3, &light[(p * s.views + v) * 4]);
        const std::size_t n = (lh * s.pixels() + p) * s.views + v;
        if (held_out(p, l * s.views + v, pairs)) bits[n / 32] |= std::uint32_t(1) << (n % 32);
      }
    }
    device.upload(*residual, std::as_bytes(std::span<const float>(light)),
                  lh * per_light * 4 * sizeof(float));
  }
  held_bits = device.buffer(bits.size() * sizeof(std::uint32_t));
  device.upload_values<std::uint32_t>(*held_bits, bits);
  const auto angles = [this](const auto& ab) {
    std::vector<float> a(2 * ab.size());
    for (std::size_t i = 0; i < ab.size(); ++i)
      for (std::size_t j = 0; j < 2; ++j) a[2 * i + j] = float(ab[i][j]);
    auto b = device.buffer(a.size() * sizeof(float));
    device.upload_values<float>(*b, a);
    return b;
  };
  light_ab = angles(s.light_ab);
  view_ab = angles(s.view_ab);
  slots_buffer = device.buffer(s.held_size() * 8 * sizeof(float));
  group_errors = device.buffer(held * groups_per_light(s.views) * 2 * sizeof(double));
  for (auto* b : {&pixel_t, &pixel_r}) *b = device.buffer(s.pixels() * m * sizeof(float));
  for (auto* b : {&light_t, &light_r}) *b = device.buffer(s.lights * m * sizeof(float));
  for (auto* b : {&view_t, &view_r}) *b = device.buffer(s.views * m * sizeof(float));
  parameters = device.buffer(m * kComponentVectors * 4 * sizeof(float));
  const std::uint32_t chunks = gpu_chunks(s.pixels());
  chunk_sums = device.buffer(held * chunks * kRows * m * sizeof(double));
  sums = device.buffer(held * kRows * m * sizeof(double));
  totals = device.buffer(kRows * m * sizeof(double));
  const std::size_t blocks = (m + kBlock - 1) / kBlock;
  gram_blocks = device.buffer(blocks * blocks * kBlock * kBlock * sizeof(double));
  rhs_blocks = device.buffer(blocks * kBlock * 3 * sizeof(double));
}

// Per component its parameters (refine_tables.comp's 5 vec4), uploaded; the parts of t_m
// (Eq. 9-10) made from them on the device, both ways.
void GpuPredictionPass::State::make_tables(const ProductMixture& mix) {
  const std::vector<float> c = component_vectors(mix);
  device.upload_values<float>(*parameters, c);
  const TablesPush push{std::uint32_t(m),       std::uint32_t(s.pixels()), std::uint32_t(s.lights),
                        std::uint32_t(s.views), std::uint32_t(s.width),    float(periods[0]),
                        float(periods[1])};
  GpuBuffer* bound[] = {parameters.get(), light_ab.get(), view_ab.get(),
                        pixel_r.get(),    light_r.get(),  view_r.get(),
                        pixel_t.get(),    light_t.get(),  view_t.get()};
  const auto [gx, gy] = groups_for((s.pixels() + s.lights + s.views) * m, kTableGroup);
  device.run(*tables, bound, bytes_of(push), gx, gy);
}

// Each held light's squared error and samples: its workgroups' sums added in order.
std::vector<double> GpuPredictionPass::State::light_errors(std::size_t per_pixel) {
  const std::size_t per = groups_per_light(per_pixel), held = s.held_lights();
  std::vector<double> groups(held * per * 2);
  device.download(*group_errors, std::as_writable_bytes(std::span<double>(groups)));
  std::vector<double> out(2 * held, 0.0);
  for (std::size_t lh = 0; lh < held; ++lh)
    for (std::size_t i = 0; i < per; ++i) {
      out[2 * lh] += groups[2 * (lh * per + i)];
      out[2 * lh + 1] += groups[2 * (lh * per + i) + 1];
    }
  return out;
}

// The totals result() takes but the error: kRows rows of M sums over every light, then each
// light's sum g (M a light). Each (row, light)'s chunks added in chunk order on the device;
// the lights in light order, on the device for one process, else on the host over the
// processes (fold_over_processes), the same order.
std::vector<double> GpuPredictionPass::State::totals_of(std::uint32_t chunks) {
  const std::size_t held = s.held_lights(), at_light = kRows * m;
  sum(*chunk_sums, *sums, m, chunks, kRows * held);
  std::vector<double> t(at_light + s.lights * m, 0.0);
  if (!s.processes || s.processes->size() == 1) {
    sum(*sums, *totals, m, held, kRows);
    device.download_values<double>(*totals, std::span<double>(t.data(), at_light));
    device.download_values<double>(
        *sums, std::span<double>(t.data() + at_light + s.first_light * m, held * m));
    return t;
  }
  std::vector<double> rows(held * kRows * m);
  device.download_values<double>(*sums, rows);
  return fold_over_processes(s.processes.get(), t.size(), [&](std::vector<double>& total) {
    for (std::size_t lh = 0; lh < held; ++lh) {
      for (std::size_t j = 0; j < kRows; ++j)
        for (std::size_t k = 0; k < m; ++k) total[j * m + k] += rows[(j * held + lh) * m + k];
      const std::size_t l = s.first_light + lh;
      for (std::size_t k = 0; k < m; ++k) total[at_light + l * m + k] += rows[lh * m + k];
    }
  });
}

PredictionGradient GpuPredictionPass::operator()(const ProductMixture& mix,
                                                 const Selection& selection, bool gradient) {
  State& g = *state_;
  const SampleSet& s = g.s;
  const std::size_t m = g.m;
  if (mix.size() != m)
    throw Error(Error::Kind::kArgument, "GpuPredictionPass: a mixture of " +
                                            std::to_string(mix.size()) +
                                            " components for a pass of " + std::to_string(m));
  g.make_tables(mix);
  const auto held = std::uint32_t(s.held_lights());
  const std::uint32_t slots = g.run_errors(selection);
  // The error and the samples, each light's in light order over the processes.
  const std::vector<double> errors = g.light_errors(slots);
  const std::vector<double> error =
      fold_over_processes(s.processes.get(), 2, [&](std::vector<double>& t) {
        for (std::size_t lh = 0; lh < held; ++lh) {
          t[0] += errors[2 * lh];
          t[1] += errors[2 * lh + 1];
        }
      });
  if (!gradient) {
    PredictionGradient out;
    out.error = error[0];
    out.samples = std::size_t(error[1]);
    return out;
  }
  const std::uint32_t chunks = gpu_chunks(s.pixels());
  const StatisticsPush sp{std::uint32_t(m),
                          std::uint32_t(s.pixels()),
                          std::uint32_t(s.views),
                          held,
                          std::uint32_t(s.first_light),
                          std::uint32_t(s.width),
                          chunks,
                          slots,
                          float(g.periods[0]),
                          float(g.periods[1])};
  GpuBuffer* sb[] = {g.pixel_r.get(), g.light_r.get(),      g.view_r.get(),    g.parameters.get(),
                     g.view_ab.get(), g.slots_buffer.get(), g.chunk_sums.get()};
  g.device.run(*g.statistics, sb, bytes_of(sp),
               std::uint32_t((m + kColumnsPerGroup - 1) / kColumnsPerGroup), held * chunks);
  std::vector<double> total = g.totals_of(chunks);
  total.push_back(error[0]);
  total.push_back(error[1]);
  return g.result(mix, total);
}

// Per slot of `selection` (refine_errors.comp) its weights' normaliser, error and e . yhat;
// per workgroup the squared errors. Returns the slots a pixel.
std::uint32_t GpuPredictionPass::State::run_errors(const Selection& selection) {
  const auto held = std::uint32_t(s.held_lights());
  const std::size_t modulus = std::max<std::size_t>(selection.modulus, 1);
  const auto slots = std::uint32_t((s.views + modulus - 1) / modulus);
  const ErrorsPush ep{std::uint32_t(m),
                      std::uint32_t(s.pixels()),
                      std::uint32_t(s.lights),
                      std::uint32_t(s.views),
                      held,
                      std::uint32_t(s.first_light),
                      std::uint32_t(modulus),
                      std::uint32_t(selection.residue % modulus),
                      part_code(selection.part),
                      slots,
                      groups_per_light(slots)};
  GpuBuffer* eb[] = {pixel_t.get(),  light_t.get(),   view_t.get(),       parameters.get(),
                     residual.get(), held_bits.get(), slots_buffer.get(), group_errors.get()};
  const auto [gx, gy] =
      groups_for(std::size_t(held) * ep.groups_per_light * kErrorGroup, kErrorGroup);
  device.run(*errors, eb, bytes_of(ep), gx, gy);
  return slots;
}

// This process's sums of the colour refit's normal equations over the samples of `training`,
// laid out as the totals: G (M^2), b (3M), the energy (3), the count.
std::vector<double> GpuPredictionPass::State::normal_sums(const ProductMixture& mix,
                                                          const Selection& training) {
  const std::size_t at_rhs = m * m, at_energy = at_rhs + 3 * m, at_count = at_energy + 3;
  std::vector<double> mine(at_count + 1, 0.0);
  make_tables(mix);
  const std::uint32_t slots = run_errors(training);
  const std::vector<double> counted = light_errors(slots);
  const std::size_t blocks = (m + kBlock - 1) / kBlock;
  const NormalPush push{std::uint32_t(m),
                        std::uint32_t(s.pixels()),
                        std::uint32_t(s.views),
                        std::uint32_t(s.held_lights()),
                        std::uint32_t(s.first_light),
                        slots,
                        std::uint32_t(blocks)};
  GpuBuffer* bound[] = {pixel_r.get(),      light_r.get(),     view_r.get(),    residual.get(),
                        slots_buffer.get(), gram_blocks.get(), rhs_blocks.get()};
  device.run(*normal, bound, bytes_of(push), std::uint32_t(blocks), std::uint32_t(blocks));
  std::vector<double> gram(blocks * blocks * kBlock * kBlock), rhs(blocks * kBlock * 3);
  device.download_values<double>(*gram_blocks, gram);
  device.download_values<double>(*rhs_blocks, rhs);
  for (std::size_t a = 0; a < m; ++a)
    for (std::size_t b = a; b < m; ++b) {
      const std::size_t block = (a / kBlock) * blocks + b / kBlock;
      const double v = gram[block * kBlock * kBlock + (a % kBlock) * kBlock + b % kBlock];
      mine[a * m + b] = mine[b * m + a] = v;
    }
  std::copy_n(rhs.begin(), 3 * m, mine.begin() + std::ptrdiff_t(at_rhs));
  const std::size_t pairs = s.lights * s.views;
  for (std::size_t l = s.first_light; l < s.light_end(); ++l)
    for (std::size_t p = 0; p < s.pixels(); ++p)
      for (std::size_t v = 0; v < s.views; ++v)
        if (training.takes(p, l * s.views + v, pairs))
          for (int c = 0; c < 3; ++c) {
            const double r = s.residual_of(p, l, v, c);
            mine[at_energy + std::size_t(c)] += r * r;
          }
  for (std::size_t lh = 0; lh < s.held_lights(); ++lh) mine[at_count] += counted[2 * lh + 1];
  return mine;
}

ColourNormalEquations GpuPredictionPass::normal_equations(
    const ProductMixture& mix, std::size_t stride, const std::atomic<bool>* stop,
    const std::function<void(double)>& progress) {
  State& g = *state_;
  const SampleSet& s = g.s;
  const std::size_t m = g.m;
  const Selection training{std::max<std::size_t>(stride, 1), 0, Selection::Part::kTraining};
  // Counted over the lights of every process, so that each refuses alike.
  const std::size_t samples =
      s.pixels() * s.lights * ((s.views + training.modulus - 1) / training.modulus);
  check_loop_nest(g.device.info(), (samples + 15) / 16, "the colour refit's normal equations");
  const std::size_t at_rhs = m * m, at_energy = at_rhs + 3 * m, at_count = at_energy + 3;
  // Zeros where stopped: every process takes part in the fold.
  const std::vector<double> mine =
      stop && stop->load() ? std::vector<double>(at_count + 1, 0.0) : g.normal_sums(mix, training);
  const std::vector<double> total =
      fold_over_processes(s.processes.get(), mine.size(), [&](std::vector<double>& t) {
        for (std::size_t i = 0; i < t.size(); ++i) t[i] += mine[i];
      });
  ColourNormalEquations eq;
  eq.components = m;
  eq.gram.assign(total.begin(), total.begin() + std::ptrdiff_t(at_rhs));
  eq.rhs.assign(total.begin() + std::ptrdiff_t(at_rhs), total.begin() + std::ptrdiff_t(at_energy));
  for (std::size_t c = 0; c < 3; ++c) eq.energy[c] = total[at_energy + c];
  eq.samples = std::size_t(total[at_count]);
  if (progress) progress(1.0);
  return eq;
}

// The gradient of the totals (kRows rows of M, each light's sum g, the error, the samples):
// the parameters' derivatives as GradientPass::result forms them.
PredictionGradient GpuPredictionPass::State::result(const ProductMixture& mix,
                                                    const std::vector<double>& total) const {
  PredictionGradient out;
  out.error = total[total.size() - 2];
  out.samples = std::size_t(total[total.size() - 1]);
  out.log_weight.assign(m, 0.0);
  out.mean.assign(m, {});
  out.log_var.assign(m, {});
  const auto row = [&](std::size_t j, std::size_t k) { return total[j * m + k]; };
  for (std::size_t k = 0; k < m; ++k) {
    out.log_weight[k] = row(0, k);
    for (std::size_t n = 0; n < 2; ++n) {
      out.mean[k][n] = row(1 + n, k);
      out.log_var[k][n] = row(3 + n, k);
      out.mean[k][4 + n] = row(5 + n, k);
      out.log_var[k][4 + n] = row(7 + n, k);
    }
    for (std::size_t c = 0; c < 3; ++c) out.mean[k][6 + c] = row(9 + c, k);
    for (std::size_t l = 0; l < s.lights; ++l)
      for (std::size_t j = 0; j < 2; ++j)
        add_angle_gradient(total[kRows * m + l * m + k], s.light_ab[l][j], k, 2 + j, mix, out);
  }
  return out;
}

}  // namespace btfgmm::detail
