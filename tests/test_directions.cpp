// Directions, the signed onion-slice parameterisation, and interpolation weights.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(Directions, Ubo81PresetHasTheRingsOfTheDatabases) {
  const DirectionSet s = DirectionSet::ubo81();
  ASSERT_EQ(s.size(), 81u);
  const int counts[] = {1, 6, 12, 18, 20, 24};
  std::size_t i = 0;
  for (int ring = 0; ring < 6; ++ring)
    for (int k = 0; k < counts[ring]; ++k, ++i) {
      EXPECT_DOUBLE_EQ(s[i].theta_deg, 15.0 * ring);
      EXPECT_NEAR(s[i].phi_deg, 360.0 * k / counts[ring], 1e-12);
    }
  // Bonn image 8 is light 0, view 8 = (30, 30).
  EXPECT_DOUBLE_EQ(s[8].theta_deg, 30.0);
  EXPECT_DOUBLE_EQ(s[8].phi_deg, 30.0);
}

TEST(Directions, OnionSliceOfThe81PresetIsDistinctAndRoundTrips) {
  const DirectionSet s = DirectionSet::ubo81();
  std::set<std::pair<long long, long long>> seen;
  for (const Direction& d : s) {
    const OnionSlice o = to_onion_slice(d);
    seen.insert({std::llround(o.alpha * 1e6), std::llround(o.beta * 1e6)});
    const Vec3 v = to_vector(d), w = from_onion_slice(o);
    EXPECT_NEAR(v.x, w.x, 1e-9);
    EXPECT_NEAR(v.y, w.y, 1e-9);
    EXPECT_NEAR(v.z, w.z, 1e-9);
    const Direction back = to_direction(w);
    EXPECT_NEAR(angular_distance_deg(back, d), 0.0, 1e-9);
    if (d.theta_deg > 0) {
      EXPECT_NEAR(back.theta_deg, d.theta_deg, 1e-9);
      EXPECT_NEAR(std::remainder(back.phi_deg - d.phi_deg, 360.0), 0.0, 1e-9);
    }
  }
  EXPECT_EQ(seen.size(), 81u);
}

TEST(Directions, OnionSliceKeepsTheSignThePrintedFormulaDrops) {
  // (theta, phi) and (theta, -phi) are different directions: alpha must differ in sign.
  const OnionSlice a = to_onion_slice(Direction{45, 60});
  const OnionSlice b = to_onion_slice(Direction{45, 300});
  EXPECT_NEAR(a.beta, b.beta, 1e-12);
  EXPECT_NEAR(a.alpha, -b.alpha, 1e-12);
  EXPECT_GT(a.alpha, 0.1);
  // The paper's printed xi_3 = acos(cos t / cos xi_4) equals |alpha|.
  const double t = 45 * kPi / 180, p = 300 * kPi / 180;
  const double xi4 = std::asin(std::sin(t) * std::cos(p));
  const double xi3 = std::acos(std::cos(t) / std::cos(xi4));
  EXPECT_NEAR(xi4, b.beta, 1e-12);
  EXPECT_NEAR(xi3, std::abs(b.alpha), 1e-9);
}

TEST(Directions, OnionSliceKnownValues) {
  // Along +x: beta = theta, alpha = 0. Along +y: beta = 0, alpha = theta.
  const OnionSlice x = to_onion_slice(Direction{30, 0});
  EXPECT_NEAR(x.beta, kPi / 6, 1e-12);
  EXPECT_NEAR(x.alpha, 0.0, 1e-12);
  const OnionSlice y = to_onion_slice(Direction{30, 90});
  EXPECT_NEAR(y.beta, 0.0, 1e-12);
  EXPECT_NEAR(y.alpha, kPi / 6, 1e-12);
  const OnionSlice n = to_onion_slice(Direction{0, 123});
  EXPECT_NEAR(n.alpha, 0.0, 1e-12);
  EXPECT_NEAR(n.beta, 0.0, 1e-12);
}

TEST(Directions, RandomDirectionsRoundTrip) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> th(0.0, 90.0), ph(0.0, 360.0);
  for (int i = 0; i < 1000; ++i) {
    const Direction d{th(rng), ph(rng)};
    const Vec3 v = from_onion_slice(to_onion_slice(d));
    EXPECT_NEAR(angular_distance_deg(to_direction(v), d), 0.0, 1e-6);
  }
}

TEST(Directions, ParseSpecs) {
  EXPECT_EQ(DirectionSet::parse("ubo81").size(), 81u);
  EXPECT_EQ(DirectionSet::parse("spiral:151").size(), 151u);
  const DirectionSet r = DirectionSet::parse("rings:0/1,30/6,60/12");
  ASSERT_EQ(r.size(), 19u);
  EXPECT_DOUBLE_EQ(r[7].theta_deg, 60.0);
  EXPECT_DOUBLE_EQ(r[8].phi_deg, 30.0);
  EXPECT_THROW(DirectionSet::parse("ubo82"), Error);
  EXPECT_THROW(DirectionSet::parse("spiral:0"), Error);
  EXPECT_THROW(DirectionSet::parse("spiral:x"), Error);
  EXPECT_THROW(DirectionSet::parse("rings:95/3"), Error);
  EXPECT_THROW(DirectionSet::parse("rings:30"), Error);
  EXPECT_THROW(DirectionSet::parse("rings:30/2.5"), Error);
}

TEST(Directions, SpiralIsDistinctSortedAndOnTheHemisphere) {
  const DirectionSet s = DirectionSet::spiral(151);
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_GE(s[i].theta_deg, 0.0);
    EXPECT_LE(s[i].theta_deg, 80.0);
    EXPECT_NEAR(s[i].theta_deg * 10, std::round(s[i].theta_deg * 10), 1e-9);
    for (std::size_t j = 0; j < i; ++j) EXPECT_GT(angular_distance_deg(s[i], s[j]), 1.0);
    if (i > 0) {
      EXPECT_LE(s[i - 1].theta_deg, s[i].theta_deg);
    }
  }
}

TEST(Directions, FindMatchesWithinTolerance) {
  const DirectionSet s = DirectionSet::ubo81();
  EXPECT_EQ(s.find(Direction{30, 30}), std::optional<std::size_t>(8));
  EXPECT_EQ(s.find(Direction{0, 77}), std::optional<std::size_t>(0));  // the pole
  EXPECT_FALSE(s.find(Direction{31, 30}).has_value());
  EXPECT_EQ(s.find(Direction{75, 359.9999999}), std::optional<std::size_t>(57));
}

// Projected area of a triangle on the disk, for the coverage check.
double tri_area(const DirectionSet& s, const std::array<std::uint32_t, 3>& t) {
  const Vec3 a = to_vector(s[t[0]]), b = to_vector(s[t[1]]), c = to_vector(s[t[2]]);
  return 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

void check_weights(const DirectionSet& s, const DirectionInterpolator::Weights& w,
                   const Direction& q, bool inside) {
  double sum = 0, x = 0, y = 0;
  for (int k = 0; k < 3; ++k) {
    ASSERT_GE(w.weight[k], 0.0);
    ASSERT_LT(w.index[k], s.size());
    sum += w.weight[k];
    const Vec3 v = to_vector(s[w.index[k]]);
    x += w.weight[k] * v.x;
    y += w.weight[k] * v.y;
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  if (inside) {  // barycentric weights reproduce the query's projection
    const Vec3 v = to_vector(q);
    EXPECT_NEAR(x, v.x, 1e-9);
    EXPECT_NEAR(y, v.y, 1e-9);
  }
}

TEST(Interpolation, TriangulationCoversTheDiskOfThe81Preset) {
  const DirectionSet s = DirectionSet::ubo81();
  const DirectionInterpolator interp(s);
  // Euler: a triangulation of n points with h on the hull has 2n - 2 - h triangles.
  EXPECT_EQ(interp.triangles().size(), 2u * 81 - 2 - 24);
  double area = 0;
  for (const auto& t : interp.triangles()) area += tri_area(s, t);
  const double r = std::sin(75 * kPi / 180);
  const double polygon = 0.5 * 24 * r * r * std::sin(2 * kPi / 24);  // the 75-degree ring
  EXPECT_NEAR(area, polygon, 1e-9);
}

// Area of the convex hull of the projected set (Andrew's monotone chain).
double hull_area(const DirectionSet& s) {
  std::vector<std::pair<double, double>> p;
  for (const Direction& d : s) p.emplace_back(to_vector(d).x, to_vector(d).y);
  std::sort(p.begin(), p.end());
  auto cross = [](auto o, auto a, auto b) {
    return (a.first - o.first) * (b.second - o.second) -
           (a.second - o.second) * (b.first - o.first);
  };
  std::vector<std::pair<double, double>> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  double a = 0;
  for (std::size_t i = 0; i + 1 < k; ++i)
    a += h[i].first * h[i + 1].second - h[i + 1].first * h[i].second;
  return 0.5 * a;
}

TEST(Interpolation, TriangulationCoversTheHullOfASpiralSet) {
  const DirectionSet s = DirectionSet::spiral(151);
  const DirectionInterpolator interp(s);
  double area = 0;
  for (const auto& t : interp.triangles()) area += tri_area(s, t);
  EXPECT_NEAR(area, hull_area(s), 1e-9);
}

TEST(Interpolation, WeightsAreConvexAndReproduceMeasuredDirections) {
  for (const DirectionSet& s :
       {DirectionSet::ubo81(), DirectionSet::spiral(151), DirectionSet::parse("rings:10/3,50/5")}) {
    const DirectionInterpolator interp(s);
    for (std::size_t i = 0; i < s.size(); ++i) {
      const auto w = interp.weights(s[i]);
      int hits = 0;
      for (int k = 0; k < 3; ++k)
        if (w.weight[k] == 1.0) {
          ++hits;
          // the same direction (or one projecting onto the same point)
          EXPECT_NEAR(angular_distance_deg(s[w.index[k]], s[i]), 0.0, 1e-9);
        }
      EXPECT_EQ(hits, 1) << "direction " << i;
    }
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> th(0.0, 90.0), ph(0.0, 360.0);
    for (int i = 0; i < 2000; ++i) {
      const Direction q{th(rng), ph(rng)};
      check_weights(s, interp.weights(q), q, false);
    }
  }
}

TEST(Interpolation, InsideTheMeasuredRangeWeightsAreBarycentric) {
  const DirectionSet s = DirectionSet::ubo81();
  const DirectionInterpolator interp(s);
  // The 75-degree ring polygon reaches down to theta = asin(sin 75 cos 7.5) = 73.3 degrees.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> th(0.0, 73.0), ph(0.0, 360.0);
  for (int i = 0; i < 2000; ++i) {
    const Direction q{th(rng), ph(rng)};
    check_weights(s, interp.weights(q), q, true);
  }
  // Halfway between two neighbours of the 75-degree ring: half and half.
  const auto w = interp.weights(Direction{75, 7.5});
  double w57 = 0, w58 = 0;
  for (int k = 0; k < 3; ++k) {
    if (w.index[k] == 57) w57 += w.weight[k];
    if (w.index[k] == 58) w58 += w.weight[k];
  }
  EXPECT_NEAR(w57, 0.5, 1e-9);
  EXPECT_NEAR(w58, 0.5, 1e-9);
}

TEST(Interpolation, BeyondTheLastRingClampsToTheHull) {
  const DirectionSet s = DirectionSet::ubo81();
  const DirectionInterpolator interp(s);
  // theta = 89 at phi = 0 lies beyond measured (75, 0): all weight on it.
  const auto w = interp.weights(Direction{89, 0});
  double w57 = 0;
  for (int k = 0; k < 3; ++k)
    if (w.index[k] == 57) w57 += w.weight[k];
  EXPECT_NEAR(w57, 1.0, 1e-12);
}

TEST(Interpolation, DegenerateSets) {
  const DirectionSet one({Direction{10, 20}});
  const auto w1 = DirectionInterpolator(one).weights(Direction{50, 100});
  EXPECT_EQ(w1.index[0], 0u);
  EXPECT_DOUBLE_EQ(w1.weight[0] + w1.weight[1] + w1.weight[2], 1.0);
  const DirectionSet two({Direction{30, 0}, Direction{30, 180}});
  const auto w2 = DirectionInterpolator(two).weights(Direction{0, 0});
  EXPECT_NEAR(w2.weight[0], 0.5, 1e-12);
  EXPECT_THROW(DirectionInterpolator(DirectionSet{}), Error);
}

}  // namespace
}  // namespace btfgmm
