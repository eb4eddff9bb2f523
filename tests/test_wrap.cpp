// The tile wraps: EM fits the spatial Gaussians on the circle of the tile, the prediction is
// continuous where the repeated tile meets itself (x = W is x = 0, y = H is y = 0) in predict()
// and in the render kernel, and a rendered sphere shows no seam along the tile's edges
// (docs/ALGORITHM.md, "The tile wraps"; docs/RENDERING.md, "Seams").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/render/render.hpp"

namespace btfgmm {
namespace {

// The difference b - a of two tile coordinates on the circle of period p.
double circular(double d, double p) {
  return d - p * std::round(d / p);
}

// A generated knit tile (its images repeat without seams) and a model fitted to it.
const Btf& knit_tile() {
  static const Btf b = [] {
    GenerateConfig g;
    g.material = "knit";
    g.size = 16;
    g.seed = 5;
    g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
    g.views = DirectionSet::parse("rings:0/1,45/5");
    g.supersample = 1;
    return generate(g);
  }();
  return b;
}

const BtfModel& knit_model() {
  static const BtfModel m = [] {
    FitConfig c;
    c.components = 60;
    c.seed = 3;
    c.em.max_iterations = 6;
    return fit_model(knit_tile(), c);
  }();
  return m;
}

TEST(Wrap, EmFitsTheSpatialGaussiansOnTheCircleOfTheTile) {
  // A 16 x 16 tile, one light and one view: the pixels with x in {14, 15, 0, 1, 2} (within 2
  // of x = 0 across the edge) are bright, the others dark. Two components, one started on
  // each: the bright one's x is the circular mean 0 with variance (4 + 1 + 0 + 1 + 4) / 5 = 2;
  // the dark one's x, 3..13, has mean 8 and variance (11^2 - 1) / 12 = 10, held at the
  // ceiling (16 / 8)^2 = 4. Both spread over every row: y's mean 7.5, its variance
  // (16^2 - 1) / 12 = 21.25 held at the ceiling.
  SampleSet s;
  s.width = s.height = 16;
  s.lights = s.views = 1;
  s.light_ab = s.view_ab = {{0.0, 0.0}};
  s.mean_brdf = {100, 100, 100};
  s.residual.resize(s.size() * 3);
  for (std::size_t p = 0; p < s.pixels(); ++p) {
    const double x = double(p % 16);
    const bool bright = std::abs(circular(x, 16)) <= 2.0;
    for (int c = 0; c < 3; ++c) s.residual[p * 3 + std::size_t(c)] = bright ? 60.0f : -30.0f;
  }
  ProductMixture mix;
  mix.weight = {0.5, 0.5};
  mix.mean = {{0.5, 8, 0, 0, 0, 0, 50, 50, 50}, {8, 8, 0, 0, 0, 0, -20, -20, -20}};
  mix.var = {{4, 4, 1, 1, 1, 1, 100, 100, 100}, {4, 4, 1, 1, 1, 1, 100, 100, 100}};
  EmConfig c;
  c.max_iterations = 5;
  const EmResult r = fit_em(s, mix, c);
  ASSERT_EQ(mix.size(), 2u);
  for (std::size_t i = 1; i < r.log_likelihood.size(); ++i)
    EXPECT_GE(r.log_likelihood[i], r.log_likelihood[i - 1] - 1e-9);
  const std::size_t bright = mix.mean[0][6] > mix.mean[1][6] ? 0 : 1, dark = 1 - bright;
  EXPECT_NEAR(mix.weight[bright], 5.0 / 16.0, 1e-9);
  EXPECT_GE(mix.mean[bright][0], 0.0);  // kept in [0, W)
  EXPECT_LT(mix.mean[bright][0], 16.0);
  EXPECT_NEAR(circular(mix.mean[bright][0], 16), 0.0, 1e-6);
  EXPECT_NEAR(mix.var[bright][0], 2.0, 1e-6);
  EXPECT_NEAR(mix.mean[dark][0], 8.0, 1e-6);
  EXPECT_EQ(mix.var[dark][0], 4.0);  // sigma_x <= W / 8
  for (const std::size_t m : {bright, dark}) {
    EXPECT_NEAR(mix.mean[m][1], 7.5, 1e-6);
    EXPECT_EQ(mix.var[m][1], 4.0);  // sigma_y <= H / 8
  }
}

// Along lines of the tile at steps of h pixels (x from 0 to W - h at fixed y, and y from 0 to
// H - h at fixed x), for several pairs of directions: the jump across the edge, between
// W - h and 0, and the largest jump between neighbours inside the tile, each the largest over
// the three channels. `eval` maps queries to colours.
struct EdgeJumps {
  double edge = 0.0, inside = 0.0;
};
template <class Eval>
std::vector<EdgeJumps> edge_jumps(const BtfModel& m, double h, Eval eval) {
  const Direction dirs[][2] = {{{30, 45}, {0, 0}}, {{60, 200}, {45, 72}}, {{10, 300}, {45, 144}}};
  std::vector<EdgeJumps> out;
  for (int axis = 0; axis < 2; ++axis)
    for (const double at : {0.0, 5.0, 10.5})
      for (const auto& d : dirs) {
        const int side = axis == 0 ? m.width : m.height;
        const int n = int(std::lround(side / h));
        std::vector<Query> q(static_cast<std::size_t>(n));
        for (int k = 0; k < n; ++k)
          q[std::size_t(k)] =
              axis == 0 ? Query{k * h, at, d[0], d[1]} : Query{at, k * h, d[0], d[1]};
        const std::vector<float> rgb = eval(q);
        auto jump = [&](int a, int b) {
          double j = 0.0;
          for (int c = 0; c < 3; ++c)
            j = std::max(
                j, double(std::abs(rgb[std::size_t(a * 3 + c)] - rgb[std::size_t(b * 3 + c)])));
          return j;
        };
        EdgeJumps e;
        e.edge = jump(n - 1, 0);
        for (int k = 0; k + 1 < n; ++k) e.inside = std::max(e.inside, jump(k, k + 1));
        out.push_back(e);
      }
  return out;
}

void expect_continuous(const std::vector<EdgeJumps>& jumps, const char* what) {
  double worst = 0.0;
  for (std::size_t i = 0; i < jumps.size(); ++i) {
    EXPECT_LE(jumps[i].edge, jumps[i].inside) << what << ", line " << i;
    worst = std::max(worst, jumps[i].edge / jumps[i].inside);
  }
  std::printf("%s: the jump across the tile's edge is at most %.2f of the largest inside it\n",
              what, worst);
}

TEST(Wrap, PredictionIsContinuousAcrossTheTileEdge) {
  // The jump between W - h and 0 (and H - h and 0) is no larger than the largest jump between
  // neighbours h apart inside the tile, h = 1/16 pixel.
  const BtfModel& m = knit_model();
  expect_continuous(edge_jumps(m, 1.0 / 16,
                               [&](const std::vector<Query>& q) {
                                 std::vector<float> rgb(q.size() * 3);
                                 predict(m, q, rgb);
                                 return rgb;
                               }),
                    "predict()");
}

// The render kernel on a line's points, in groups of 16 (blocks of 1 pixel of the tile, whose
// boxes are tight, one of them across the tile's edge: the points are given from the middle
// of the line on, so the edge falls inside a group), against predict().
std::vector<float> kernel_colours(const ModelEvaluator& ev, const BtfModel& m,
                                  const std::vector<Query>& q, double tolerance) {
  const std::size_t n = q.size(), half = n / 2;
  std::vector<SurfacePoint> pts(n);
  std::vector<Query> rotated(n);
  for (std::size_t r = 0; r < n; ++r) {
    const Query& a = q[(r + half) % n];
    const Vec3 l = to_vector(a.light), v = to_vector(a.view);
    pts[r].x = float(a.x);
    pts[r].y = float(a.y);
    pts[r].light = {float(l.x), float(l.y), float(l.z)};
    pts[r].view = {float(v.x), float(v.y), float(v.z)};
    rotated[r] = {pts[r].x, pts[r].y, to_direction({l.x, l.y, l.z}), to_direction({v.x, v.y, v.z})};
  }
  std::vector<std::uint32_t> groups = {0};
  for (std::uint32_t g = 8; g < n; g += 16) groups.push_back(g);
  std::vector<float> got(n * 3), want(n * 3), rgb(n * 3);
  ev.evaluate(pts, got, groups);
  predict(m, rotated, want);
  double worst = 0.0;
  for (std::size_t i = 0; i < got.size(); ++i)
    worst = std::max(worst, double(std::abs(got[i] - want[i])));
  EXPECT_LT(worst, tolerance + 1e-3);
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t c = 0; c < 3; ++c) rgb[((r + half) % n) * 3 + c] = got[r * 3 + c];
  return rgb;
}

TEST(Wrap, RenderKernelIsContinuousAcrossTheTileEdge) {
  // As predict(), and equal to it within the tolerance in blocks that hold the tile's edge,
  // or a component's antipode, or neither.
  const BtfModel& m = knit_model();
  for (const double tolerance : {0.0, 0.1}) {
    const ModelEvaluator ev(m, tolerance);
    expect_continuous(edge_jumps(m, 1.0 / 16,
                                 [&](const std::vector<Query>& q) {
                                   return kernel_colours(ev, m, q, tolerance);
                                 }),
                      tolerance > 0 ? "the render kernel, tolerance 0.1" : "the render kernel");
  }
}

// The seam statistic of a rendering, along the tile's x (axis 0) or y (axis 1): every pair of
// neighbouring lit pixels (right and below) whose texture coordinates lie within 1/4 pixel of
// each other and step mostly along the axis gives |colour difference| / texture distance
// (levels per tile pixel); the pairs are binned by the tile coordinate of their midpoint, 8
// bins a tile pixel. The profile of the bins' means less, per bin, the median of its four
// nearest neighbours (two each side) shows a seam as a spike; returned is the largest
// robust z-score of that difference, (d - median) / (1.4826 MAD).
double seam_score(const SurfaceBuffer& sb, const Rendering& r, int tile_w, int tile_h, int axis) {
  const int period = axis == 0 ? tile_w : tile_h, bins = 8 * period;
  std::vector<int> point_of(std::size_t(sb.width) * std::size_t(sb.height), -1);
  for (std::size_t i = 0; i < sb.points.size(); ++i) point_of[sb.pixel[i]] = int(i);
  std::vector<double> sum(static_cast<std::size_t>(bins), 0.0), count(sum);
  auto luminance = [&](std::size_t pixel) {
    return (r.rgb[pixel * 3] + r.rgb[pixel * 3 + 1] + r.rgb[pixel * 3 + 2]) / 3.0;
  };
  for (int y = 0; y + 1 < sb.height; ++y)
    for (int x = 0; x + 1 < sb.width; ++x) {
      const std::size_t pa = std::size_t(y) * std::size_t(sb.width) + std::size_t(x);
      for (const std::size_t pb : {pa + 1, pa + std::size_t(sb.width)}) {
        if (point_of[pa] < 0 || point_of[pb] < 0) continue;
        const SurfacePoint &a = sb.points[std::size_t(point_of[pa])],
                           &b = sb.points[std::size_t(point_of[pb])];
        const double dx = circular(b.x - a.x, tile_w), dy = circular(b.y - a.y, tile_h);
        const double step = std::hypot(dx, dy), along = axis == 0 ? dx : dy;
        if (!(step > 0.0) || step > 0.25 || std::abs(along) < std::abs(axis == 0 ? dy : dx))
          continue;
        double mid = (axis == 0 ? a.x : a.y) + 0.5 * along;
        mid -= period * std::floor(mid / period);
        const std::size_t bin = std::size_t(std::min(int(mid / period * bins), bins - 1));
        sum[bin] += std::abs(luminance(pb) - luminance(pa)) / step;
        count[bin] += 1.0;
      }
    }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const auto nbins = static_cast<std::size_t>(bins);
  std::vector<double> profile(nbins), d(nbins), dev;
  for (int b = 0; b < bins; ++b) {
    EXPECT_GE(count[std::size_t(b)], 20.0) << "bin " << b << " of axis " << axis;
    profile[std::size_t(b)] = sum[std::size_t(b)] / std::max(count[std::size_t(b)], 1.0);
  }
  for (int b = 0; b < bins; ++b) {
    std::vector<double> near;
    for (const int k : {-2, -1, 1, 2}) near.push_back(profile[std::size_t((b + k + bins) % bins)]);
    d[std::size_t(b)] = profile[std::size_t(b)] - median(near);
  }
  const double md = median(d);
  for (const double v : d) dev.push_back(std::abs(v - md));
  const double mad = 1.4826 * median(dev);
  double worst = 0.0;
  for (const double v : d) worst = std::max(worst, (v - md) / mad);
  return worst;
}

TEST(Wrap, RenderedSphereShowsNoSeam) {
  // The model and the data (whose tile repeats without seams) on a sphere of 64 x 32 quads, the
  // tile repeated twice a unit of u (4 tiles around, 2 from pole to pole): no column or row of
  // the tile stands out from its neighbours by a robust z-score above 8. Measured: the model
  // 2.7 along x and 1.9 along y, the data 3.4 and 3.3; with the spatial Gaussians unwrapped
  // 84 and 154, with the frames of the sphere's u = 0 meridian one-sided 19 along x.
  const BtfModel& m = knit_model();
  const Btf& data = knit_tile();
  RenderSettings s;
  s.width = s.height = 200;
  s.repeat = 2;
  const SurfaceBuffer sb = rasterize(make_sphere(64, 32), Camera::orbit({60, 20}, 1.0),
                                     Light::directional({40, 60}), s, m.width, m.height);
  const Rendering model = render(sb, ModelEvaluator(m), s, m.format);
  const Rendering measured = render(sb, DataEvaluator(data), s, data.format());
  for (int axis = 0; axis < 2; ++axis) {
    const double zm = seam_score(sb, model, m.width, m.height, axis);
    const double zd = seam_score(sb, measured, m.width, m.height, axis);
    std::printf("seam score along %c: model %.1f, data %.1f\n", axis == 0 ? 'x' : 'y', zm, zd);
    EXPECT_LT(zm, 8.0) << "the model's rendering, axis " << axis;
    EXPECT_LT(zd, 8.0) << "the data's rendering, axis " << axis;
  }
}

TEST(Wrap, FramesAgreeAcrossTheSeamOfTheTextureCoordinates) {
  // The sphere's u = 0 and u = 2 meridians are one curve: its vertices, one copy on each side,
  // must carry one frame (one-sided sums differ by a slice, 360 / 64 = 5.6 degrees), else the
  // light and view directions, and with them the colours, jump there.
  for (const Mesh& mesh : {make_sphere(64, 32), make_cylinder(48, 4)}) {
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < mesh.position.size(); ++i)
      for (std::size_t j = i + 1; j < mesh.position.size(); ++j) {
        const Vec3 &a = mesh.position[i], &b = mesh.position[j];
        if (std::abs(a.x - b.x) + std::abs(a.y - b.y) + std::abs(a.z - b.z) > 1e-9 ||
            std::abs(mesh.normal[i].z) > 0.99)
          continue;  // not one point, or a pole
        ++pairs;
        const Vec3 &t = mesh.tangent[i], &u = mesh.tangent[j];
        EXPECT_NEAR(t.x * u.x + t.y * u.y + t.z * u.z, 1.0, 1e-12) << i << " " << j;
        const Vec3 &p = mesh.bitangent[i], &q = mesh.bitangent[j];
        EXPECT_NEAR(p.x * q.x + p.y * q.y + p.z * q.z, 1.0, 1e-12) << i << " " << j;
      }
    EXPECT_GT(pairs, 4u);
  }
}

}  // namespace
}  // namespace btfgmm
