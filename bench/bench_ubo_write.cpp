// Writes the Bonn .btf file of the .btf benchmark (bench/bench-ubo.sh) with the tests' writer
// (tests/ubo_btf_writer.hpp): a DFMF of W x H pixels and the UBO2014 sampling's size (151 lights
// x 151 views: rings of 1, 6, 12, 18, 24, 30, 30, 30 directions up to 75 degrees), colour model
// 11, C components per channel, the factors random (seeded) as half floats.
//
//   bench_ubo_write FILE [--size W] [--components C]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <random>
#include <string>

#include "../tests/ubo_btf_writer.hpp"

namespace {

std::vector<btfgmm::test::UboAngles> rings151() {
  std::vector<btfgmm::test::UboAngles> d;
  const int counts[] = {1, 6, 12, 18, 24, 30, 30, 30};
  for (int r = 0; r < 8; ++r)
    for (int k = 0; k < counts[r]; ++k)
      d.push_back({float(r * 75.0 / 7.0 * std::numbers::pi / 180.0),
                   float(2.0 * std::numbers::pi * k / counts[r])});
  return d;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_ubo_write FILE [--size W] [--components C]\n");
    return 2;
  }
  int size = 400, components = 20;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string o = argv[i];
    if (o == "--size")
      size = std::atoi(argv[i + 1]);
    else if (o == "--components")
      components = std::atoi(argv[i + 1]);
    else
      return std::fprintf(stderr, "bench_ubo_write: unknown option %s\n", o.c_str()), 2;
  }
  btfgmm::test::UboSpec s;
  s.lights = s.views = rings151();
  s.width = s.height = std::uint32_t(size);
  s.colour_model = 11;
  std::mt19937 rng(7);
  std::normal_distribution<float> n(0.0f, 1.0f);
  std::vector<btfgmm::test::UboFactors> f(3);
  const Eigen::Index rows = Eigen::Index(s.lights.size() * s.views.size());
  for (std::size_t c = 0; c < 3; ++c) {
    f[c].s = Eigen::VectorXf::LinSpaced(components, 100.0f, 1.0f);
    f[c].u = Eigen::MatrixXf::NullaryExpr(rows, components, [&] { return 0.01f * n(rng); });
    f[c].sxv = Eigen::MatrixXf::NullaryExpr(Eigen::Index(size) * size, components,
                                            [&] { return 0.05f * n(rng); });
  }
  const std::vector<std::uint8_t> bytes = btfgmm::test::write_ubo_btf(s, f);
  std::ofstream(argv[1], std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  std::printf("wrote %s: %zu bytes, %zu lights x %zu views, %d x %d pixels, %d components\n",
              argv[1], bytes.size(), s.lights.size(), s.views.size(), size, size, components);
  return 0;
}
