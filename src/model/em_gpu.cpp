// The E pass of the grid EM on a compute device (em_gpu.hpp). Per pass:
//   the tables     S, L, V (transposed: a view's columns side by side), the colour means and
//                  -1/(2 sigma^2), the view means and the pixels' minimum-image distances;
//   normaliser     per sample its largest log density and 1 / sum exp, Eq. (4), and per
//                  workgroup of one light its samples' terms of L, Eq. (3);
//   statistics     per (light, chunk of pixels, column) the 15 sums of the M-step;
//   light sums     each light's chunks added in chunk order;
// then each light's numbers assembled by light_statistics and its L's terms added in
// workgroup order, all on the host in a fixed order: the same result for any number of
// threads, and for a given device, run after run.
#include "model/em_gpu.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "gpu/device_check.hpp"
#include "model/em_light_statistics.hpp"
#include "model/gpu_passes.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::uint32_t kNormaliserGroup = 256;  // em_normaliser.comp's local size
constexpr std::uint32_t kColumnsPerGroup = 64;   // em_statistics.comp's columns a workgroup
constexpr std::uint32_t kRows = 15;              // em_statistics.comp's sums per column

struct NormaliserPush {
  std::uint32_t stride, components, pixels, views, held, first_light, groups_per_light;
};
struct StatisticsPush {
  std::uint32_t stride, components, pixels, views, held, first_light, width, chunks;
};

}  // namespace

struct GpuEPass::State {
  ComputeDevice& device;
  const SampleSet& s;
  std::shared_ptr<GpuKernel> normaliser, statistics, light_sums;
  std::shared_ptr<GpuBuffer> residual, norm, view_ab;
  // Per pass, sized for the largest stride met.
  std::size_t stride = 0;
  std::shared_ptr<GpuBuffer> s_table, l_table, v_table, vt_table, colour, offsets, view_mu, terms,
      chunk_sums, sums;
  Seconds seconds;

  State(ComputeDevice& d, const SampleSet& samples) : device(d), s(samples) {}

  std::uint32_t groups_per_light() const {
    return std::uint32_t((s.pixels() * s.views + kNormaliserGroup - 1) / kNormaliserGroup);
  }

  void upload_samples();
  void size_tables(std::size_t st);
  void upload_tables(const Tables& t, const ProductMixture& mix);
  std::vector<double> light_terms();
  std::vector<double> column_sums(std::size_t st, std::uint32_t chunks);
};

double GpuEPass::device_bytes(const SampleSet& s, std::size_t components) {
  const double n = double(s.held_size()), st = double((components + 15) / 16 * 16);
  const double chunks = gpu_chunks(s.pixels()), held = double(s.held_lights());
  const double tables = 4.0 * st * double(s.pixels() + s.lights + s.views + 8) +
                        8.0 * st * double(s.width + s.height);
  return 24.0 * n + tables + 8.0 * kRows * st * held * (chunks + 1) +
         8.0 * held * 2 * std::ceil(double(s.pixels() * s.views) / kNormaliserGroup);
}

GpuEPass::GpuEPass(ComputeDevice& device, const SampleSet& s)
    : state_(std::make_unique<State>(device, s)) {
  check_device_holds(device.info(), device_bytes(s, 16), 16.0 * double(s.held_size()),
                     "the fit's " + std::to_string(s.held_size()) + " samples");
  check_loop_nest(device.info(), statistics_iterations(s.pixels(), s.views), "EM's E pass");
  State& g = *state_;
  g.normaliser = device.kernel("em_normaliser.spv", 7, sizeof(NormaliserPush));
  g.statistics = device.kernel("em_statistics.spv", 10, sizeof(StatisticsPush));
  g.light_sums = chunk_sums_kernel(device);
  g.upload_samples();
}

GpuEPass::~GpuEPass() = default;

// The residual colours (r, g, b, 0), light-major (held light, pixel, view), a light at a time; the
// view angles; room for each sample's normaliser.
void GpuEPass::State::upload_samples() {
  const std::size_t per_light = s.pixels() * s.views * 4;
  residual = device.buffer(s.held_size() * 4 * sizeof(float));
  norm = device.buffer(s.held_size() * 2 * sizeof(float));
  std::vector<float> light(per_light, 0.0f), block(s.views * 3);
  for (std::size_t lh = 0; lh < s.held_lights(); ++lh) {
    for (std::size_t p = 0; p < s.pixels(); ++p) {
      s.block_residuals(p, s.first_light + lh, block.data());
      for (std::size_t v = 0; v < s.views; ++v)
        std::copy_n(&block[3 * v], 3, &light[(p * s.views + v) * 4]);
    }
    device.upload(*residual, std::as_bytes(std::span<const float>(light)),
                  lh * per_light * sizeof(float));
  }
  std::vector<float> ab(2 * s.views);
  for (std::size_t v = 0; v < s.views; ++v) {
    ab[2 * v] = float(s.view_ab[v][0]);
    ab[2 * v + 1] = float(s.view_ab[v][1]);
  }
  view_ab = device.buffer(ab.size() * sizeof(float));
  device.upload_values<float>(*view_ab, ab);
}

void GpuEPass::State::size_tables(std::size_t st) {
  if (st <= stride) return;
  stride = st;
  const std::uint32_t chunks = gpu_chunks(s.pixels());
  s_table = device.buffer(s.pixels() * st * 4);
  l_table = device.buffer(s.lights * st * 4);
  v_table = device.buffer(s.views * st * 4);
  vt_table = device.buffer(s.views * st * 4);
  colour = device.buffer(8 * st * 4);
  offsets = device.buffer(std::size_t(s.width + s.height) * st * 8);
  view_mu = device.buffer(2 * st * 4);
  terms = device.buffer(s.held_lights() * groups_per_light() * 8);
  chunk_sums = device.buffer(s.held_lights() * chunks * kRows * st * 8);
  sums = device.buffer(s.held_lights() * kRows * st * 8);
}

void GpuEPass::State::upload_tables(const Tables& t, const ProductMixture& mix) {
  const std::size_t st = t.stride;
  size_tables(st);
  device.upload_values<float>(*s_table, t.s);
  device.upload_values<float>(*l_table, t.l);
  // V both ways: a view's columns side by side (the statistics: a workgroup's columns) and a
  // column's views side by side (the normaliser: a workgroup's samples).
  device.upload_values<float>(*v_table, t.v);
  std::vector<float> vt(st * s.views);
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t k = 0; k < st; ++k) vt[k * s.views + v] = t.v[v * st + k];
  device.upload_values<float>(*vt_table, vt);
  std::vector<float> c(8 * st, 0.0f);  // per column: (mu, 0), (h, 0)
  for (std::size_t k = 0; k < st; ++k)
    for (std::size_t ch = 0; ch < 3; ++ch) {
      c[8 * k + ch] = t.mu[ch * st + k];
      c[8 * k + 4 + ch] = t.neg_half_inv_var[ch * st + k];
    }
  device.upload_values<float>(*colour, c);
  std::vector<double> o(t.dx);
  o.insert(o.end(), t.dy.begin(), t.dy.end());
  device.upload_values<double>(*offsets, o);
  std::vector<float> mu(2 * st, 0.0f);
  for (std::size_t k = 0; k < t.m; ++k) {
    mu[k] = float(mix.mean[t.order[k]][4]);
    mu[st + k] = float(mix.mean[t.order[k]][5]);
  }
  device.upload_values<float>(*view_mu, mu);
}

// Each held light's terms of L: its workgroups' sums added in order.
std::vector<double> GpuEPass::State::light_terms() {
  const std::size_t per = groups_per_light();
  std::vector<double> groups(s.held_lights() * per);
  device.download_values<double>(*terms, groups);
  std::vector<double> out(s.held_lights(), 0.0);
  for (std::size_t lh = 0; lh < out.size(); ++lh)
    for (std::size_t i = 0; i < per; ++i) out[lh] += groups[lh * per + i];
  return out;
}

// Each held light's 15 rows of st sums: the chunks' (em_statistics), added in chunk order.
std::vector<double> GpuEPass::State::column_sums(std::size_t st, std::uint32_t chunks) {
  sum_chunks(device, *light_sums, *chunk_sums, *sums, kRows * st, chunks, s.held_lights());
  std::vector<double> out(s.held_lights() * kRows * st);
  device.download_values<double>(*sums, out);
  return out;
}

std::vector<std::vector<double>> GpuEPass::run(const Tables& t, const ProductMixture& mix,
                                               const Periods& periods, bool stats) {
  State& g = *state_;
  const SampleSet& s = g.s;
  auto at = Clock::now();
  auto lap = [&at](double& into) {
    into += seconds_since(at);
    at = Clock::now();
  };
  g.upload_tables(t, mix);
  lap(g.seconds.upload);
  const auto st = std::uint32_t(g.stride), held = std::uint32_t(s.held_lights());
  const NormaliserPush np{
      st,   std::uint32_t(t.m),           std::uint32_t(s.pixels()), std::uint32_t(s.views),
      held, std::uint32_t(s.first_light), g.groups_per_light()};
  GpuBuffer* nb[] = {g.s_table.get(),  g.l_table.get(), g.vt_table.get(), g.colour.get(),
                     g.residual.get(), g.norm.get(),    g.terms.get()};
  const std::uint32_t groups = held * np.groups_per_light;
  const std::uint32_t gx = std::min(groups, kMaxGroupsX);
  g.device.run(*g.normaliser, nb, bytes_of(np), gx, (groups + gx - 1) / gx);
  lap(g.seconds.normaliser);
  const std::vector<double> ll = g.light_terms();
  std::vector<std::vector<double>> out(held);
  if (!stats) {
    for (std::size_t lh = 0; lh < held; ++lh) out[lh] = {ll[lh]};
    return out;
  }
  const std::uint32_t chunks = gpu_chunks(s.pixels());
  const StatisticsPush sp{
      st,   std::uint32_t(t.m),           std::uint32_t(s.pixels()), std::uint32_t(s.views),
      held, std::uint32_t(s.first_light), std::uint32_t(s.width),    chunks};
  GpuBuffer* sb[] = {g.s_table.get(),  g.l_table.get(),   g.v_table.get(), g.colour.get(),
                     g.residual.get(), g.norm.get(),      g.offsets.get(), g.view_ab.get(),
                     g.view_mu.get(),  g.chunk_sums.get()};
  g.device.run(*g.statistics, sb, bytes_of(sp), (st + kColumnsPerGroup - 1) / kColumnsPerGroup,
               held * chunks);
  const std::vector<double> rows = g.column_sums(st, chunks);
  lap(g.seconds.statistics);
  for (std::size_t lh = 0; lh < held; ++lh) {
    const double* r = &rows[lh * kRows * st];
    const ColumnSums sums{ll[lh], r, r + st, r + 5 * st, r + 9 * st, r + 12 * st};
    out[lh] = light_statistics(s, t, mix, s.first_light + lh, sums, periods);
  }
  lap(g.seconds.host);
  return out;
}

const GpuEPass::Seconds& GpuEPass::seconds() const {
  return state_->seconds;
}

}  // namespace btfgmm::detail
