// splitmix64 (Steele, Lea & Flood 2014, "Fast splittable pseudorandom number generators"):
// the one source of random numbers of the library (the mixture's initialisation, the
// synthetic materials). Deterministic from the seed, whatever the number of threads.
#pragma once

#include <cstdint>

namespace btfgmm::detail {

// The splitmix64 output function: a bijective 64-bit mix.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// The splitmix64 generator: the state advances by the golden gamma, the output is its mix.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix64(state_);
  }
  // Uniform in [0, 1) from the top 53 bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  std::uint64_t state_;
};

}  // namespace btfgmm::detail
