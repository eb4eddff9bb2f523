// The renderer: meshes and tangent frames, the geometry pass against analytic values, the OBJ
// path against the built-in plane, the model kernel against predict(), model and data
// renders where the model is exact, the comparison figure, the render and tile commands.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/render/font.hpp"
#include "btfgmm/render/render.hpp"
#include "btfgmm/render/scene.hpp"
#include "test_util.hpp"

namespace {

using namespace btfgmm;
namespace fs = std::filesystem;

constexpr double kPi = std::numbers::pi;

double dot(const Vec3& a, const Vec3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 normalized(const Vec3& a) {
  const double l = std::sqrt(dot(a, a));
  return {a.x / l, a.y / l, a.z / l};
}

const char* kLights = "rings:0/1,30/4,60/6";
const char* kViews = "rings:0/1,45/5";

Btf small_btf(const std::string& material, int size) {
  GenerateConfig g;
  g.material = material;
  g.size = size;
  g.seed = 5;
  g.lights = DirectionSet::parse(kLights);
  g.views = DirectionSet::parse(kViews);
  g.supersample = 1;
  return generate(g);
}

const BtfModel& small_model() {
  static const BtfModel m = [] {
    FitConfig c;
    c.components = 60;
    c.seed = 3;
    c.em.max_iterations = 6;
    return fit_model(small_btf("knit", 16), c);
  }();
  return m;
}

// The world ray through the centre of pixel (px, py), as rasterize() projects.
Vec3 pixel_ray(const Camera& c, int w, int h, int px, int py) {
  const Vec3 fwd = normalized({c.target.x - c.eye.x, c.target.y - c.eye.y, c.target.z - c.eye.z});
  const Vec3 right = normalized(cross(fwd, c.up));
  const Vec3 up = cross(right, fwd);
  const double focal = 0.5 * h / std::tan(0.5 * c.fov_deg * kPi / 180.0);
  const double sx = (px + 0.5 - 0.5 * w) / focal, sy = (py + 0.5 - 0.5 * h) / focal;
  return normalized({fwd.x + sx * right.x - sy * up.x, fwd.y + sx * right.y - sy * up.y,
                     fwd.z + sx * right.z - sy * up.z});
}

TEST(Mesh, BuiltInFramesAreOrthonormalAndRightHanded) {
  for (const Mesh& m : {make_sphere(48, 24), make_cylinder(48, 4), make_cloth(40), make_plane(3)}) {
    ASSERT_EQ(m.tangent.size(), m.position.size());
    ASSERT_FALSE(m.triangles.empty());
    for (std::size_t i = 0; i < m.position.size(); ++i) {
      const Vec3 &n = m.normal[i], &t = m.tangent[i], &b = m.bitangent[i];
      EXPECT_NEAR(dot(n, n), 1.0, 1e-9);
      EXPECT_NEAR(dot(t, t), 1.0, 1e-9);
      EXPECT_NEAR(dot(t, n), 0.0, 1e-9);
      EXPECT_NEAR(dot(b, n), 0.0, 1e-9);
      // u along x, v along y, normal out: the texture's frame is right-handed on every
      // built-in mesh (the BTF's x, y, z).
      EXPECT_GT(dot(cross(t, b), n), 0.5) << "vertex " << i;
    }
  }
  // The sphere's tangent at the equator points east, its bitangent north.
  const Mesh s = make_sphere(64, 32);
  for (std::size_t i = 0; i < s.position.size(); ++i) {
    const Vec3& p = s.position[i];
    if (std::abs(p.z) > 0.5) continue;
    const double az = std::atan2(p.y, p.x);
    EXPECT_NEAR(dot(s.tangent[i], {-std::sin(az), std::cos(az), 0.0}), 1.0, 2e-3);
    EXPECT_NEAR(s.bitangent[i].z, std::sqrt(p.x * p.x + p.y * p.y), 2e-3);
  }
}

// Two unit squares side by side, the second's texture coordinates turned by 25 degrees and
// moved by 3 in u (a seam where the texture continues), the vertices of the edge between them
// in two copies `gap` apart: within 1e-9 of the extent the copies share dP/du and dP/dv (equal
// frames), farther apart each keeps its own (25 degrees apart). The squares are put at random
// places, so that some copies lie on either side of a face of the cells that group them.
TEST(Mesh, SeamCopiesShareTheirFrameWhereTheyCoincide) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double c = std::cos(25 * kPi / 180), s = std::sin(25 * kPi / 180);
  const double xy[8][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {1, 0}, {2, 0}, {2, 1}, {1, 1}};
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3 o{u(rng), u(rng), u(rng)}, d = normalized({u(rng), u(rng), u(rng)});
    const double extent = std::max(
        {std::abs(o.x), std::abs(o.x + 2), std::abs(o.y), std::abs(o.y + 1), std::abs(o.z)});
    const bool near = trial % 4 != 0;  // one in four: copies 3 cells apart
    const double gap = (near ? 0.9 : 3.0) * 1e-9 * extent;
    Mesh m;
    for (int i = 0; i < 8; ++i) {
      const double g = i == 4 || i == 7 ? gap : 0.0, x = xy[i][0], y = xy[i][1];
      m.position.push_back({x + o.x + g * d.x, y + o.y + g * d.y, o.z + g * d.z});
      m.normal.push_back({0, 0, 1});
      m.uv.push_back(i < 4 ? std::array<double, 2>{x / 2, y / 2}
                           : std::array<double, 2>{3 + (c * x - s * y) / 2, (s * x + c * y) / 2});
    }
    m.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}};
    compute_tangent_frames(m);
    for (const auto& [a, b] : {std::pair{1, 4}, std::pair{2, 7}}) {
      const Vec3 &ta = m.tangent[std::size_t(a)], &tb = m.tangent[std::size_t(b)];
      if (near) {
        EXPECT_TRUE(ta.x == tb.x && ta.y == tb.y && ta.z == tb.z) << "trial " << trial;
      } else {
        EXPECT_NEAR(dot(ta, tb), c, 1e-6) << "trial " << trial;
      }
    }
  }
}

TEST(Render, SphereFramesAndDirectionsMatchAnalyticValues) {
  const Mesh sphere = make_sphere();
  const Camera cam = Camera::orbit({60, 20}, sphere.radius());
  const Direction light_dir{45, 30};
  RenderSettings s;
  s.width = s.height = 160;
  s.repeat = 1;
  const int tw = 32;
  const SurfaceBuffer sb = rasterize(sphere, cam, Light::directional(light_dir), s, tw, tw);
  ASSERT_EQ(sb.points.size(), sb.pixel.size());
  ASSERT_EQ(sb.block_start.back(), sb.points.size());
  const Vec3 L = to_vector(light_dir);
  std::size_t checked = 0, lit_inside = 0;
  std::vector<int> point_of(std::size_t(s.width) * std::size_t(s.height), -1);
  for (std::size_t i = 0; i < sb.pixel.size(); ++i) point_of[sb.pixel[i]] = int(i);
  for (int py = 0; py < s.height; ++py)
    for (int px = 0; px < s.width; ++px) {
      const std::size_t pix = std::size_t(py) * std::size_t(s.width) + std::size_t(px);
      // The ray against the unit sphere.
      const Vec3 d = pixel_ray(cam, s.width, s.height, px, py);
      const double b = dot(cam.eye, d), c = dot(cam.eye, cam.eye) - 1.0, disc = b * b - c;
      if (disc < -0.02) {
        EXPECT_EQ(sb.coverage[pix], 0) << px << "," << py;  // clearly off the sphere
        continue;
      }
      if (disc < 0.02) continue;  // the silhouette, tessellated
      EXPECT_NE(sb.coverage[pix], 0) << "a hole at " << px << "," << py;
      const double t = -b - std::sqrt(disc);
      const Vec3 P{cam.eye.x + t * d.x, cam.eye.y + t * d.y, cam.eye.z + t * d.z};
      const Vec3 N = P;
      const Vec3 east = normalized({-P.y, P.x, 0.0}), north = cross(N, east);
      const double nl = dot(N, L);
      if (nl < -0.02) {
        EXPECT_EQ(sb.coverage[pix], 1) << "lit on the dark side";
      }
      if (nl < 0.02 || std::abs(P.z) > 0.9) continue;  // the terminator; near the poles
      ASSERT_EQ(sb.coverage[pix], 2);
      ++lit_inside;
      const SurfacePoint& sp = sb.points[std::size_t(point_of[pix])];
      // Light and view in the frame (east, north, normal).
      const Vec3 V = normalized({cam.eye.x - P.x, cam.eye.y - P.y, cam.eye.z - P.z});
      const double want_l[3] = {dot(L, east), dot(L, north), nl};
      const double want_v[3] = {dot(V, east), dot(V, north), dot(V, N)};
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(sp.light[std::size_t(k)], want_l[k], 0.01) << px << "," << py << " k " << k;
        if (want_v[2] > 0.05) {
          EXPECT_NEAR(sp.view[std::size_t(k)], want_v[k], 0.01);
        }
      }
      // Texture coordinates: u = azimuth / pi, v = polar angle from the south pole / pi,
      // times repeat x tile width, wrapped into the tile.
      double az = std::atan2(P.y, P.x);
      if (az < 0) az += 2 * kPi;
      const double want_x = std::fmod(az / kPi * tw, tw),
                   want_y = std::fmod(std::acos(-P.z) / kPi * tw, tw);
      double dx = std::abs(sp.x - want_x), dy = std::abs(sp.y - want_y);
      dx = std::min(dx, tw - dx);
      dy = std::min(dy, tw - dy);
      EXPECT_LT(dx, 0.05) << px << "," << py;
      EXPECT_LT(dy, 0.05) << px << "," << py;
      ++checked;
    }
  EXPECT_GT(checked, 3000u);
  EXPECT_EQ(checked, lit_inside);
}

TEST(Render, ObjQuadEqualsTheBuiltInPlane) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_render_obj_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    std::ofstream obj(dir / "quad.obj");
    obj << "# two triangles\n"
           "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
           "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
           "vn 0 0 1\n"
           "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n";
    std::ofstream bare(dir / "bare.obj");
    bare << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n";
  }
  const Mesh quad = load_obj(dir / "quad.obj");
  const Mesh plane = make_plane(1);
  ASSERT_EQ(quad.triangles.size(), 2u);
  const Btf data = small_btf("corduroy", 16);
  const DataEvaluator ev(data);
  RenderSettings s;
  s.width = s.height = 96;
  s.repeat = 2;
  for (const Direction cam_dir : {Direction{0, 90}, Direction{50, 200}}) {
    const Camera cam = Camera::orbit(cam_dir, plane.radius());
    const Light light = Light::directional({40, 70});
    const Rendering a = render(rasterize(quad, cam, light, s, 16, 16), ev, s, data.format());
    const Rendering b = render(rasterize(plane, cam, light, s, 16, 16), ev, s, data.format());
    ASSERT_EQ(a.object, b.object);
    EXPECT_GT(std::count(a.object.begin(), a.object.end(), 1), 2000);
    float diff = 0;
    for (std::size_t i = 0; i < a.rgb.size(); ++i)
      diff = std::max(diff, std::abs(a.rgb[i] - b.rgb[i]));
    EXPECT_LT(diff, 1e-3f);
  }
  // A face without texture coordinates: the message says so and names the file.
  try {
    load_obj(dir / "bare.obj");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), Error::Kind::kFormat);
    EXPECT_NE(std::string(e.what()).find("texture coordinates"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("bare.obj"), std::string::npos);
  }
  EXPECT_THROW(load_obj(dir / "missing.obj"), Error);
  EXPECT_THROW(make_mesh("teapot"), Error);
  fs::remove_all(dir);
}

TEST(Render, PlaneShowsTheBtfAtTheGivenDirections) {
  // Seen from straight above with the light on a measured direction, the plane shows the
  // measured image itself (bilinear at pixel centres that fall between texels).
  const Btf data = small_btf("corduroy", 16);
  const DataEvaluator ev(data);
  const Mesh plane = make_plane(1);
  RenderSettings s;
  s.width = s.height = 64;
  s.repeat = 0.5;  // the plane (u, v in [0, 1]) shows half a tile: 8 texels
  Camera cam;
  cam.eye = {0, 0, 50};
  cam.up = {0, 1, 0};
  cam.fov_deg = 2.0 * std::atan(1.0 / 50.0) * 180.0 / kPi;  // the plane fills the frame
  const SurfaceBuffer sb = rasterize(plane, cam, Light::directional({30, 90}), s, 16, 16);
  std::vector<float> rgb(sb.points.size() * 3);
  ev.evaluate(sb.points, rgb);
  const std::size_t light = *data.lights().find({30, 90}), view = *data.views().find({0, 0});
  auto texel = [&](int x, int y, int c) { return double(data.at(light, view, x % 16, y % 16, c)); };
  std::size_t n = 0;
  for (std::size_t i = 0; i < sb.points.size(); ++i) {
    const SurfacePoint& p = sb.points[i];
    EXPECT_NEAR(p.view[2], 1.0, 1e-3);  // nearly orthographic, from above
    EXPECT_LT(p.x, 8.01f);
    // Within 0.3 degrees of the pole the view's interpolation weighs the pole's image > 99 %.
    if (p.view[2] < std::cos(0.3 * kPi / 180.0)) continue;
    // The measured image, bilinear between pixel centres at whole coordinates.
    const int x = int(p.x), y = int(p.y);
    const double fx = double(p.x) - x, fy = double(p.y) - y;
    for (int c = 0; c < 3; ++c) {
      const double want = (1 - fx) * (1 - fy) * texel(x, y, c) +
                          fx * (1 - fy) * texel(x + 1, y, c) + (1 - fx) * fy * texel(x, y + 1, c) +
                          fx * fy * texel(x + 1, y + 1, c);
      EXPECT_NEAR(rgb[i * 3 + std::size_t(c)], want, 1.5) << p.x << "," << p.y;
    }
    ++n;
  }
  EXPECT_GT(n, 100u);
}

TEST(Render, ModelKernelEqualsPredict) {
  const BtfModel& m = small_model();
  ASSERT_GE(m.mixture.size(), 40u);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<SurfacePoint> pts(3000);
  std::vector<Query> queries(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Direction l{89.0 * u(rng), 360.0 * u(rng)}, v{89.0 * u(rng), 360.0 * u(rng)};
    const Vec3 lv = to_vector(l), vv = to_vector(v);
    SurfacePoint& p = pts[i];
    p.x = float(m.width * u(rng));
    p.y = float(m.height * u(rng));
    p.light = {float(lv.x), float(lv.y), float(lv.z)};
    p.view = {float(vv.x), float(vv.y), float(vv.z)};
    // The query predict() gets: exactly the directions the kernel gets (float vectors).
    queries[i] = {.x = p.x,
                  .y = p.y,
                  .light = to_direction({p.light[0], p.light[1], p.light[2]}),
                  .view = to_direction({p.view[0], p.view[1], p.view[2]})};
  }
  std::vector<float> want(pts.size() * 3);
  predict(m, queries, want);
  {
    // A point that is not finite, or a direction below the horizon: an error, wherever the
    // point lies among the others.
    const ModelEvaluator ev(m, 0.1);
    std::vector<float> got(pts.size() * 3);
    for (const std::size_t at : {std::size_t(0), std::size_t(1234)}) {
      std::vector<SurfacePoint> bad = pts;
      bad[at].x = std::numeric_limits<float>::quiet_NaN();
      EXPECT_THROW(ev.evaluate(bad, got), Error);
      bad = pts;
      bad[at].view[2] = -0.5f;
      EXPECT_THROW(ev.evaluate(bad, got), Error);
    }
  }
  for (const double tolerance : {0.0, 1e-3, 0.05}) {
    const ModelEvaluator ev(m, tolerance);
    std::vector<float> got(pts.size() * 3);
    const EvaluationStats st = ev.evaluate(pts, got);
    EXPECT_EQ(st.points, pts.size());
    EXPECT_EQ(st.nominal, pts.size() * m.mixture.size());
    double worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
      worst = std::max(worst, double(std::abs(got[i] - want[i])));
    EXPECT_LT(worst, tolerance + 1e-3) << "tolerance " << tolerance;
  }
}

TEST(Render, SkippedComponentsStayWithinTheTolerance) {
  // Screen blocks of a rendered sphere: tight boxes, where the bound skips components.
  const BtfModel& m = small_model();
  const Mesh sphere = make_sphere(64, 32);
  RenderSettings s;
  s.width = s.height = 96;
  s.repeat = 2;
  const SurfaceBuffer sb = rasterize(sphere, Camera::orbit({50, 10}, 1.0),
                                     Light::directional({40, 60}), s, m.width, m.height);
  std::vector<Query> q(sb.points.size());
  for (std::size_t i = 0; i < q.size(); ++i) {
    const SurfacePoint& p = sb.points[i];
    q[i] = {.x = p.x,
            .y = p.y,
            .light = to_direction({p.light[0], p.light[1], p.light[2]}),
            .view = to_direction({p.view[0], p.view[1], p.view[2]})};
  }
  std::vector<float> want(q.size() * 3);
  predict(m, q, want);
  for (const double tolerance : {0.01, 0.5}) {
    const ModelEvaluator ev(m, tolerance);
    std::vector<float> got(q.size() * 3);
    const EvaluationStats st = ev.evaluate(sb.points, got, sb.block_start);
    EXPECT_LT(st.evaluated, st.nominal) << "nothing skipped at tolerance " << tolerance;
    double worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
      worst = std::max(worst, double(std::abs(got[i] - want[i])));
    EXPECT_LT(worst, tolerance + 1e-3) << "tolerance " << tolerance;
  }
}

TEST(Render, ModelAndDataAgreeWhereTheModelIsExact) {
  // Every pixel of an image equals that image's mean: the mean BRDF is the data, and a
  // model of M = 1 predicts the mean BRDF (its colour mean is the zero residual).
  Btf flat(DirectionSet::parse(kLights), DirectionSet::parse(kViews), 8, 8, SampleFormat::kLdr8);
  for (std::size_t l = 0; l < flat.lights().size(); ++l)
    for (std::size_t v = 0; v < flat.views().size(); ++v) {
      const Direction& dl = flat.lights()[l];
      const Direction& dv = flat.views()[v];
      const double base = 40.0 + 150.0 * std::cos(dl.theta_deg * kPi / 180.0) +
                          20.0 * std::sin(dv.phi_deg * kPi / 180.0);
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
          for (int c = 0; c < 3; ++c)
            flat.at(l, v, x, y, c) = float(std::round(base * (1.0 - 0.2 * c)));
    }
  FitConfig c;
  c.components = 1;
  c.em.max_iterations = 2;
  const BtfModel m = fit_model(flat, c);
  ASSERT_EQ(m.mixture.size(), 1u);
  RenderSettings s;
  s.width = s.height = 120;
  s.repeat = 3;
  for (const char* mesh_name : {"sphere", "cloth"}) {
    const Mesh mesh = make_mesh(mesh_name);
    const SurfaceBuffer sb = rasterize(mesh, Camera::orbit({55, 30}, mesh.radius(), mesh.center()),
                                       Light::directional({35, 120}), s, 8, 8);
    const Rendering a = render(sb, ModelEvaluator(m), s, m.format);
    const Rendering b = render(sb, DataEvaluator(flat), s, flat.format());
    float worst = 0;
    for (std::size_t i = 0; i < a.rgb.size(); ++i)
      worst = std::max(worst, std::abs(a.rgb[i] - b.rgb[i]));
    EXPECT_LE(worst, 1.0f) << mesh_name;
    const RenderComparison cmp = compare_renderings(b, a);
    EXPECT_LT(cmp.rmse, 0.5) << mesh_name;
    EXPECT_GT(cmp.ssim, 0.99) << mesh_name;
  }
}

TEST(Render, FastDirectionInterpolatorEqualsDirectionInterpolator) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (const char* spec : {"ubo81", "spiral:151", "rings:0/1,30/4,60/6", "rings:45/1"}) {
    const DirectionSet set = DirectionSet::parse(spec);
    const DirectionInterpolator slow(set);
    const FastDirectionInterpolator fast(set);
    std::uint32_t hint = 0xFFFFFFFFu;
    Vec3 walk = to_vector({20, 10});
    for (int i = 0; i < 4000; ++i) {
      // Random directions (some below the horizon), and a coherent walk using the hint.
      const Vec3 r = to_vector({95.0 * u(rng), 360.0 * u(rng)});
      walk = normalized({walk.x + 0.02 * (u(rng) - 0.5), walk.y + 0.02 * (u(rng) - 0.5),
                         std::abs(walk.z + 0.02 * (u(rng) - 0.5))});
      for (const Vec3& v : {r, walk}) {
        const auto a = slow.weights(v);
        const auto b = &v == &walk ? fast.weights(v, hint) : fast.weights(v);
        for (int k = 0; k < 3; ++k) {
          if (a.weight[std::size_t(k)] == 0.0 && b.weight[std::size_t(k)] == 0.0) continue;
          EXPECT_EQ(a.index[std::size_t(k)], b.index[std::size_t(k)]) << spec;
          EXPECT_EQ(a.weight[std::size_t(k)], b.weight[std::size_t(k)]) << spec;
        }
      }
    }
  }
}

TEST(Render, ComparisonMetricsAndFigure) {
  const Btf data = small_btf("knit", 16);
  RenderSettings s;
  s.width = s.height = 48;
  const Mesh sphere = make_sphere(48, 24);
  const SurfaceBuffer sb =
      rasterize(sphere, Camera::orbit({40, 0}, 1.0), Light::directional({30, 30}), s, 16, 16);
  const Rendering a = render(sb, DataEvaluator(data), s, data.format());
  Rendering b = a;
  RenderComparison same = compare_renderings(a, b);
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_TRUE(std::isinf(same.psnr));
  EXPECT_NEAR(same.ssim, 1.0, 1e-12);
  std::size_t on = 0;
  for (std::size_t p = 0; p < b.object.size(); ++p)
    if (b.object[p]) {
      ++on;
      for (int c = 0; c < 3; ++c)
        b.rgb[p * 3 + std::size_t(c)] =
            std::clamp(a.rgb[p * 3 + std::size_t(c)], 0.0f, 255.0f) + 2.0f;
    }
  // Values near 255 clip; everything else is off by exactly 2.
  const RenderComparison off = compare_renderings(a, b);
  EXPECT_EQ(off.pixels, on);
  EXPECT_NEAR(off.rmse, 2.0, 0.05);
  EXPECT_NEAR(off.psnr, 20.0 * std::log10(255.0 / off.rmse), 1e-9);
  EXPECT_LT(off.ssim, 1.0);
  const Image fig = comparison_figure(a, b, off);
  EXPECT_GT(fig.width, 3 * s.width);
  EXPECT_GT(fig.height, s.height);
  // The difference panel shows 10 x 2 levels on the object. The panels start under a line of
  // titles (12-pixel text at this width, and half of that as a margin).
  const int gap = (fig.width - 3 * s.width) / 2, top = label_line_height(12) + 6;
  const std::size_t centre = (std::size_t(top + s.height / 2) * std::size_t(fig.width) +
                              std::size_t(2 * (s.width + gap) + s.width / 2)) *
                             3;
  EXPECT_NEAR(fig.rgb[centre], 20.0f, 0.01f);
  // Each line of the caption's scene adds a line of text under the figure.
  const Image captioned = comparison_figure(a, b, off, 10.0, {"gm, M = 9", {"light", "camera"}});
  EXPECT_EQ(captioned.height, fig.height + 2 * label_line_height(12));
  Rendering small = a;
  small.width = 10;
  EXPECT_THROW(compare_renderings(a, small), Error);
}

// The figure's labels are drawn from a TrueType font, anti-aliased, with the Greek letters and
// signs they use; the built-in pixel font stands in only where no font file is installed.
TEST(Render, LabelsAreDrawnFromATrueTypeFont) {
  if (font_name().find(".ttf") == std::string::npos)
    GTEST_SKIP() << "no TrueType font installed (" << font_name() << "): fonts-dejavu-core";
  Image img;
  img.width = 200;
  img.height = 40;
  img.rgb.assign(std::size_t(img.width * img.height) * 3, 255.0f);
  const int w = draw_label(img, 2, 2, "θ 45° φ 30° ×10", 20, {0, 0, 0});
  EXPECT_GT(w, 100);
  EXPECT_LT(w, 200);
  EXPECT_EQ(w, label_width("θ 45° φ 30° ×10", 20));
  EXPECT_GT(label_width("θ", 20), 5);  // a glyph of its own, not a replacement
  std::size_t ink = 0, grey = 0;
  for (float v : img.rgb) {
    ink += v < 128.0f;
    grey += v > 5.0f && v < 250.0f;
  }
  EXPECT_GT(ink, 300u);
  EXPECT_GT(grey, 300u);  // anti-aliased edges, which the pixel font does not have
  EXPECT_GE(label_line_height(20), 20);
}

// ---- the commands -------------------------------------------------------------------------

struct CliRun {
  int status = 0;
  std::string out;
};

CliRun run_cli(const std::string& args) {
  const fs::path log =
      fs::temp_directory_path() / ("btfgmm_render_cli_" + std::to_string(::getpid()) + ".log");
  const std::string cmd =
      std::string(BTFGMM_CLI_PATH) + " " + args + " > " + log.string() + " 2>&1";
  CliRun r;
  const int raw = std::system(cmd.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  std::ifstream in(log);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return r;
}

TEST(RenderCli, TileFitAutoRenderAndCompare) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_render_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto p = [&](const std::string& n) { return (dir / n).string(); };
  const std::string sets = std::string(" --lights ") + kLights + " --views " + kViews;
  CliRun r = run_cli("generate --material knit --size 20 --seed 2" + sets + " -o " + p("btf"));
  ASSERT_EQ(r.status, 0) << r.out;

  // The knit repeats every 10 pixels (20 / round(20 / 10)): a 10 x 10 tile is seamless.
  r = run_cli("tile " + p("btf") + " --size 6-12x6-12 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["tile"][2], 10);
  EXPECT_EQ(j["tile"][3], 10);
  EXPECT_LT(j["seam_error"].get<double>(), 0.1);

  r = run_cli("fit " + p("btf") + " --tile auto:10x10 -M 8 --iterations 2 -o " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("seam error"), std::string::npos) << r.out;
  r = run_cli("info --json " + p("m.btfgmm"));
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["tile"][2], 10);

  r = run_cli("render " + p("m.btfgmm") + " --compare " + p("btf") +
              " --mesh cloth --size 64x48 --repeat 3 --json -o " + p("fig.png"));
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["object_pixels"].get<int>(), 300);
  EXPECT_GT(j["psnr_db"].get<double>(), 10.0);
  EXPECT_GT(j["model"]["component_evaluations_nominal"].get<double>(), 0.0);
  const Image fig = read_image(p("fig.png"));
  EXPECT_GT(fig.width, 3 * 64);

  r = run_cli("render " + p("btf") + " --tile 2,3,10,10 --mesh plane --camera 0,90 --size 32 -o " +
              p("data.png"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(read_image(p("data.png")).width, 32);

  r = run_cli("render " + p("m.btfgmm") + " --mesh " + p("nowhere.obj") + " -o " + p("x.png"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("nowhere.obj"), std::string::npos) << r.out;
  r = run_cli("render " + p("btf") + " --compare " + p("btf") + " -o " + p("x.png"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("--compare"), std::string::npos) << r.out;
  r = run_cli("tile " + p("btf") + " --size 21x8");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("no larger than the image"), std::string::npos) << r.out;
  r = run_cli("tile " + p("btf") + " --size 20x20");  // the whole image: judged across its wrap
  EXPECT_EQ(r.status, 0) << r.out;
  fs::remove_all(dir);
}

// The scene from its text: a point light as bright at the object's centre as a directional
// light of its intensity, a look-at camera aimed at the centre unless told, and each field that
// does not parse named.
TEST(Scene, BuiltFromItsTextAsTheCommandTakesIt) {
  SceneText t;
  t.mesh = "plane";
  t.point_light = "3,0,4";
  t.intensity = 2.0;
  t.eye = "0,0,5";
  const Scene s = build_scene(t);
  const Vec3 c = s.mesh.center();
  const double d2 = (3 - c.x) * (3 - c.x) + c.y * c.y + (4 - c.z) * (4 - c.z);
  EXPECT_EQ(s.light.kind, Light::Kind::kPoint);
  EXPECT_DOUBLE_EQ(s.light.intensity, 2.0 * d2);
  EXPECT_DOUBLE_EQ(s.camera.target.x, c.x);
  EXPECT_DOUBLE_EQ(s.camera.eye.z, 5.0);
  t.point_light.clear();
  t.light = "120,-90";
  EXPECT_EQ(build_scene(t).light.kind, Light::Kind::kDirectional);
  t.light = "190,0";
  EXPECT_NE(test::error_of([&] { build_scene(t); }).find("--light '190,0': theta 190"),
            std::string::npos);
  t.light = "45,30";
  t.up = "0,1";
  EXPECT_NE(test::error_of([&] { build_scene(t); }).find("--up '0,1'"), std::string::npos);
  EXPECT_NE(test::error_of([&] {
              render_settings("0x4", "40,40,40", 4, 0, 0.1, false);
            }).find("--size '0x4'"),
            std::string::npos);
  const RenderSettings r = render_settings("64x48", "1,2,3", 2, 1, 0.5, true);
  EXPECT_EQ(r.width, 64);
  EXPECT_EQ(r.height, 48);
  EXPECT_FLOAT_EQ(r.background[2], 3.0f);
}

}  // namespace
