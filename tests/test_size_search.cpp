// The search for the largest size whose file fits a budget (size_search.hpp), on files whose
// bytes are known functions of the size: straight, curved, varying from size to size as the
// compressed parameters do, refused above some size.
#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <utility>

#include "btfgmm/measure/size_search.hpp"

namespace btfgmm {
namespace {

// A method whose file has `bytes(size)` bytes and that refuses every size from `refused_from`
// up; it counts its fits.
struct FakeMethod {
  FakeMethod(std::function<std::uint64_t(std::size_t)> b, std::uint64_t budget_bytes,
             std::size_t refused = SIZE_MAX)
      : bytes(std::move(b)), budget(budget_bytes), refused_from(refused) {}

  std::function<std::uint64_t(std::size_t)> bytes;
  std::uint64_t budget = 0;
  std::size_t refused_from = SIZE_MAX;
  std::map<std::size_t, SizeProbe> fitted;

  SizeProbe probe(std::size_t size) const {
    return {.size = size, .bytes = bytes(size), .fits = bytes(size) <= budget};
  }
  FitSize fit() {
    return [this](std::size_t size) -> std::optional<SizeProbe> {
      EXPECT_EQ(fitted.count(size), 0u) << "size " << size << " fitted twice";
      if (size >= refused_from) return std::nullopt;
      fitted[size] = probe(size);
      return fitted[size];
    };
  }
  // The search ended on neighbours: `found` fits, found + 1 was fitted and is over (or refused).
  void expect_neighbours(const SizeProbe& found) const {
    EXPECT_TRUE(found.fits);
    EXPECT_LE(bytes(found.size), budget);
    if (found.size + 1 >= refused_from) return;
    ASSERT_EQ(fitted.count(found.size + 1), 1u) << "the size above " << found.size << " untried";
    EXPECT_FALSE(fitted.at(found.size + 1).fits);
  }
};

TEST(SizeSearch, BetweenTwoRungsFindsTheLargestSizeOnALineInTwoFits) {
  FakeMethod m([](std::size_t s) { return 1000 + 37 * s; }, 20000);
  const SizeProbe found = largest_size_between(m.probe(100), m.probe(600), m.budget, m.fit());
  EXPECT_EQ(found.size, 513u);  // 1000 + 37 * 513 = 19,981; 514: 20,018
  m.expect_neighbours(found);
  EXPECT_LE(m.fitted.size(), 2u);
}

TEST(SizeSearch, BetweenHalvesWhereTheLineMispredicts) {
  // Bytes growing as the square of the size: the line through the ends is far off.
  FakeMethod m([](std::size_t s) { return std::uint64_t(s) * s; }, 250000);
  const SizeProbe found = largest_size_between(m.probe(1), m.probe(1000), m.budget, m.fit());
  EXPECT_EQ(found.size, 500u);
  m.expect_neighbours(found);
  EXPECT_LE(m.fitted.size(), 20u);
}

// A mixture's compact file near 30 KB: 30 bytes a component and, from the compressed
// parameters, up to 100 bytes more or less from one size to the next, fewer bytes at a larger
// size often enough that the line's prediction, one to three sizes above the last, kept fitting.
std::uint64_t varying_bytes(std::size_t m) {
  return 7400 + 30 * m + (m * 1378 % 201) - 100;
}

TEST(SizeSearch, AboveTheLadderEndsOnNeighboursWhereBytesVaryFromSizeToSize) {
  FakeMethod m(varying_bytes, 30000);
  ASSERT_TRUE(m.probe(600).fits);
  const SizeProbe found =
      largest_size_above(m.probe(450), m.probe(600), SIZE_MAX, m.budget, m.fit());
  m.expect_neighbours(found);
  // Within the sizes the variation leaves uncertain of the largest that fits: (30000 - 7400 +
  // 100) / 30 at most, (30000 - 7400 - 100) / 30 at least.
  EXPECT_GE(found.size, 750u);
  EXPECT_LE(found.size, 756u);
  EXPECT_LE(m.fitted.size(), 10u);
}

TEST(SizeSearch, AboveTheLadderStopsBelowTheFirstSizeRefused) {
  // Every size fits; from 700 up the method refuses the tile (too few samples); 800 is the
  // refused rung, the cap.
  FakeMethod m([](std::size_t s) { return 100 + s; }, 1000000, 700);
  const SizeProbe found = largest_size_above(m.probe(450), m.probe(600), 800, m.budget, m.fit());
  EXPECT_EQ(found.size, 699u);
  for (const auto& [size, p] : m.fitted) EXPECT_LT(size, 800u);
  EXPECT_LE(m.fitted.size(), 12u);
}

TEST(SizeSearch, AboveTheLadderIsBoundedWhenEverySizeFits) {
  // A file whose bytes do not grow: no size is ever over, and nothing refuses.
  FakeMethod m([](std::size_t) { return 5000; }, 6000);
  const SizeProbe found =
      largest_size_above(m.probe(450), m.probe(600), SIZE_MAX, m.budget, m.fit());
  EXPECT_TRUE(found.fits);
  EXPECT_GT(found.size, 600u);
  EXPECT_EQ(m.fitted.size(), std::size_t(kMostSizesAbove));
}

TEST(SizeSearch, AboveTheLadderOnALineFindsTheLargestSize) {
  FakeMethod m([](std::size_t s) { return 7400 + 30 * s; }, 30000);
  const SizeProbe found =
      largest_size_above(m.probe(450), m.probe(600), SIZE_MAX, m.budget, m.fit());
  EXPECT_EQ(found.size, 753u);  // 7400 + 30 * 753 = 29,990
  m.expect_neighbours(found);
  EXPECT_LE(m.fitted.size(), 3u);
}

}  // namespace
}  // namespace btfgmm
