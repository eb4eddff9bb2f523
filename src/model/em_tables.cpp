// The tables of one iteration of the grid EM, and the colour order of the views (em_tables.hpp).
#include "model/em_tables.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "btfgmm/core/communicator.hpp"

namespace btfgmm::detail {
namespace {

// Components grouped into vectors of kLanes whose colour means (r, g, b) lie close together
// (a k-d split, mixture_internal.hpp): a sample's responsibilities concentrate on the
// components whose colour is near its own, so they share few vectors, and the vectors' colour
// boxes are small, which tightens the chunk bound of the AVX-512 pass. The order changes
// nothing but float summation order; it is a function of the parameters alone.
std::vector<std::size_t> block_order(const ProductMixture& mix) {
  return kd_order(mix, {6, 7, 8}, kLanes);
}

// One variable's exponent of Eq. (2) for table column k (component t.order[k]).
double table_gauss(const Tables& t, const ProductMixture& mix, const Periods& periods,
                   std::size_t k, int n, double x) {
  const std::size_t m = t.order[k];
  return gauss_exponent(x, mix.mean[m][n], mix.var[m][n], periods[std::size_t(n)]);
}

// The S table, P x stride: log w_m, the normalisation (`base`) and the x, y terms of each
// pixel. The x term depends on the column alone and the y term on the row alone, so each is
// computed once per column or row (their minimum images W x M and H x M times, not P x M) and
// the pixels' sums (base + x term) + y term, in the order of the plain formula, are filled in
// over the threads.
void tabulate_spatial(Tables& t, const SampleSet& s, const ProductMixture& mix,
                      const Periods& periods, const std::vector<double>& base, int threads) {
  const std::size_t m_count = t.m, st = t.stride;
  const auto width = std::size_t(s.width), height = std::size_t(s.height);
  std::vector<double> column(width * m_count), row(height * m_count);
  for (std::size_t x = 0; x < width; ++x)
    for (std::size_t k = 0; k < m_count; ++k)
      column[x * m_count + k] = base[k] + table_gauss(t, mix, periods, k, 0, double(x));
  for (std::size_t y = 0; y < height; ++y)
    for (std::size_t k = 0; k < m_count; ++k)
      row[y * m_count + k] = table_gauss(t, mix, periods, k, 1, double(y));
  t.s.resize(s.pixels() * st);
  const auto pixels = std::ptrdiff_t(s.pixels());
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::ptrdiff_t p = 0; p < pixels; ++p) {
    const double* cx = &column[(std::size_t(p) % width) * m_count];
    const double* ry = &row[(std::size_t(p) / width) * m_count];
    float* out = &t.s[std::size_t(p) * st];
    for (std::size_t k = 0; k < m_count; ++k) out[k] = float(cx[k] + ry[k]);
    std::fill(out + m_count, out + st, kAbsent);
  }
}

// The tables of log w_m F(x | m), Eq. (2), in parts: S (log w_m, the normalisation and the
// x, y terms, wrapped) per pixel, L (alpha_i, beta_i) per light, V (alpha_v, beta_v) per view, and
// the colour means and -1/(2 sigma^2) for the colour terms.
void tabulate_densities(Tables& t, const SampleSet& s, const ProductMixture& mix,
                        const Periods& periods, int threads) {
  const std::size_t m_count = t.m, st = t.stride;
  t.l.assign(s.lights * st, 0.0f);
  t.v.assign(s.views * st, 0.0f);
  t.mu.assign(3 * st, 0.0f);
  t.neg_half_inv_var.assign(3 * st, 0.0f);
  std::vector<double> base(m_count);
  for (std::size_t k = 0; k < m_count; ++k) {
    const std::size_t m = t.order[k];
    base[k] = log_density_constant(mix, m);
    for (int c = 0; c < 3; ++c) {
      t.mu[c * st + k] = float(mix.mean[m][6 + c]);
      t.neg_half_inv_var[c * st + k] = float(-0.5 / mix.var[m][6 + c]);
    }
  }
  tabulate_spatial(t, s, mix, periods, base, threads);
  auto gauss = [&](std::size_t k, int n, double x) {
    return table_gauss(t, mix, periods, k, n, x);
  };
  for (std::size_t l = 0; l < s.lights; ++l)
    for (std::size_t k = 0; k < m_count; ++k)
      t.l[l * st + k] = float(gauss(k, 2, s.light_ab[l][0]) + gauss(k, 3, s.light_ab[l][1]));
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t k = 0; k < m_count; ++k)
      t.v[v * st + k] = float(gauss(k, 4, s.view_ab[v][0]) + gauss(k, 5, s.view_ab[v][1]));
}

// What the AVX-512 pass's chunk bound reads (ChunkBound), per chunk of kLanes components:
// the largest V of each view, the box of the colour means, the largest -1/(2 sigma^2).
void tabulate_chunk_bounds(Tables& t, const SampleSet& s) {
  const std::size_t m_count = t.m, st = t.stride;
  const std::size_t chunks = st / kLanes;
  const std::size_t pc = t.padded_chunks = (chunks + kLanes - 1) / kLanes * kLanes;
  t.v_max.assign(s.views * pc, 0.0f);
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t j = 0; j < chunks; ++j)
      t.v_max[v * pc + j] =
          *std::max_element(&t.v[v * st + j * kLanes], &t.v[v * st + (j + 1) * kLanes]);
  for (int c = 0; c < 3; ++c) {
    t.lo[c].assign(pc, 0.0f);
    t.hi[c].assign(pc, 0.0f);
    t.h_max[c].assign(pc, 0.0f);
    for (std::size_t j = 0; j < chunks; ++j) {
      float lo = INFINITY, hi = -INFINITY, hm = -INFINITY;
      for (std::size_t k = j * kLanes; k < std::min(m_count, (j + 1) * kLanes); ++k) {
        lo = std::min(lo, t.mu[std::size_t(c) * st + k]);
        hi = std::max(hi, t.mu[std::size_t(c) * st + k]);
        hm = std::max(hm, t.neg_half_inv_var[std::size_t(c) * st + k]);
      }
      t.lo[c][j] = lo;
      t.hi[c][j] = hi;
      t.h_max[c][j] = hm;
    }
  }
}

// The minimum-image distances of every column x and row y of the tile to each component's
// mean x and y (dx: W x stride, dy: H x stride; 0 for padding), for the spatial sums.
void tabulate_pixel_offsets(Tables& t, const SampleSet& s, const ProductMixture& mix,
                            const Periods& periods) {
  const std::size_t st = t.stride;
  t.dx.assign(std::size_t(s.width) * st, 0.0);
  t.dy.assign(std::size_t(s.height) * st, 0.0);
  for (std::size_t k = 0; k < t.m; ++k) {
    const auto& mu = mix.mean[t.order[k]];
    for (std::size_t x = 0; x < std::size_t(s.width); ++x)
      t.dx[x * st + k] = wrapped_difference(double(x) - mu[0], periods[0]);
    for (std::size_t y = 0; y < std::size_t(s.height); ++y)
      t.dy[y * st + k] = wrapped_difference(double(y) - mu[1], periods[1]);
  }
}

}  // namespace

Periods tile_periods(const SampleSet& s, bool tile_wraps) {
  return variable_periods(tile_wraps ? TilePeriod{double(s.width), double(s.height)}
                                     : TilePeriod{});
}

Tables make_tables(const SampleSet& s, const ProductMixture& mix, const Periods& periods,
                   int threads) {
  Tables t;
  const std::size_t m_count = t.m = mix.size();
  t.stride = (m_count + kLanes - 1) / kLanes * kLanes;
  t.order = block_order(mix);
  // A component whose log density is below the sample's maximum by more than this has
  // q < e^-Delta; all of them together change the sum by less than M e^-Delta = e^-17.5
  // relative, below float's resolution (2^-24 = e^-16.6).
  t.skip_margin = float(std::log(double(m_count)) + 17.5);
  tabulate_densities(t, s, mix, periods, threads);
  tabulate_chunk_bounds(t, s);
  tabulate_pixel_offsets(t, s, mix, periods);
  return t;
}

namespace {

// Morton key of a colour (10 bits a channel over the box lo..hi).
std::uint32_t colour_key(const float* rgb, const float lo[3], const float span[3]) {
  std::uint32_t k = 0;
  for (int c = 0; c < 3; ++c) {
    const float u = span[c] > 0 ? (rgb[c] - lo[c]) / span[c] : 0.0f;
    const auto q = std::uint32_t(std::clamp(u, 0.0f, 0.9999f) * 1024.0f);
    for (int bit = 0; bit < 10; ++bit) k |= ((q >> bit) & 1u) << (3 * bit + c);
  }
  return k;
}

// The box of every process's residual colours from each one's (lo, hi).
void colour_box_of_all(const SampleSet& s, float lo[3], float hi[3]) {
  if (!s.processes) return;
  const float mine[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
  for (const std::vector<float>& r : all_gather_values<float>(*s.processes, mine))
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], r.at(std::size_t(c)));
      hi[c] = std::max(hi[c], r.at(3 + std::size_t(c)));
    }
}

}  // namespace

// The views of every (pixel, light) block in the order of their residual colours (a Morton
// key): the four samples of a group then have similar colours, so the components near one
// of them are near all four and the skip of group_pass drops more vectors (on generated data
// the live fraction falls from about 0.42 to 0.31). Grouping changes nothing but float
// summation order, and the order is a function of the data alone. One byte a sample; sets of
// more than 256 views keep their own order (empty result).
std::vector<std::uint8_t> view_order(const SampleSet& s) {
  const std::size_t nv = s.views, held = s.held_lights(), blocks = s.pixels() * held;
  if (nv > 256 || nv < 2) return {};
  const auto n = std::ptrdiff_t(blocks);
  auto block = [&](std::ptrdiff_t b, float* r) {
    s.block_residuals(std::size_t(b) / held, s.first_light + std::size_t(b) % held, r);
  };
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
#pragma omp parallel reduction(min : lo[:3]) reduction(max : hi[:3])
  {
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      block(b, r.data());
      for (std::size_t k = 0; k < nv * 3; ++k) {
        lo[k % 3] = std::min(lo[k % 3], r[k]);
        hi[k % 3] = std::max(hi[k % 3], r[k]);
      }
    }
  }
  colour_box_of_all(s, lo, hi);
  const float span[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  std::vector<std::uint8_t> order(s.size());
#pragma omp parallel
  {
    std::vector<std::pair<std::uint32_t, std::uint8_t>> key(nv);
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      const std::size_t first = std::size_t(b) * nv;
      block(b, r.data());
      for (std::size_t v = 0; v < nv; ++v)
        key[v] = {colour_key(&r[v * 3], lo, span), std::uint8_t(v)};
      std::sort(key.begin(), key.end());
      for (std::size_t v = 0; v < nv; ++v) order[first + v] = key[v].second;
    }
  }
  return order;
}

}  // namespace btfgmm::detail
