// The PNG writer (src/io/png_encode.cpp): the file decodes, by stb and by a decoder written
// here on zlib (every chunk's CRC, the zlib stream's Adler-32, the row filters), to the levels
// of the picture: each value rounded as lround rounds it (halves up) and clamped to 0..255,
// NaN 0; the same bytes with any number of threads compressing the bands of rows.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <omp.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image.hpp"

namespace {

namespace fs = std::filesystem;

// A fresh folder per test, removed afterwards.
struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("btfgmm_png_" +
                   std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
                   "_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path operator/(const std::string& name) const { return path / name; }
};

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}

// The 8-bit RGB levels of a PNG as written by write_png (no interlace, one IDAT or more), the
// chunks' CRCs and the zlib stream checked along the way.
std::vector<std::uint8_t> decode_with_zlib(const std::vector<std::uint8_t>& f, int w, int h) {
  const std::uint8_t magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(f.size() > 8 && std::equal(magic, magic + 8, f.begin()));
  std::vector<std::uint8_t> idat;
  for (std::size_t at = 8; at + 12 <= f.size();) {
    const std::uint32_t len = be32(&f[at]);
    const std::string type(f.begin() + std::ptrdiff_t(at + 4), f.begin() + std::ptrdiff_t(at + 8));
    EXPECT_EQ(crc32(0L, &f[at + 4], uInt(len + 4)), be32(&f[at + 8 + len])) << type;
    if (type == "IHDR") {
      EXPECT_EQ(be32(&f[at + 8]), std::uint32_t(w));
      EXPECT_EQ(be32(&f[at + 12]), std::uint32_t(h));
      EXPECT_EQ(f[at + 16], 8);  // bit depth
      EXPECT_EQ(f[at + 17], 2);  // RGB
      EXPECT_EQ(f[at + 20], 0);  // no interlace
    }
    if (type == "IDAT") idat.insert(idat.end(), &f[at + 8], &f[at + 8 + len]);
    at += 12 + len;
  }
  const std::size_t row = std::size_t(w) * 3;
  std::vector<std::uint8_t> raw(std::size_t(h) * (row + 1));
  uLongf n = uLongf(raw.size());
  EXPECT_EQ(uncompress(raw.data(), &n, idat.data(), uLong(idat.size())), Z_OK);  // Adler-32 too
  EXPECT_EQ(n, raw.size());
  std::vector<std::uint8_t> px(std::size_t(h) * row);
  for (std::size_t y = 0; y < std::size_t(h); ++y) {
    const std::uint8_t* in = &raw[y * (row + 1)];
    for (std::size_t i = 0; i < row; ++i) {
      const int a = i >= 3 ? px[y * row + i - 3] : 0, b = y > 0 ? px[(y - 1) * row + i] : 0;
      const int c = i >= 3 && y > 0 ? px[(y - 1) * row + i - 3] : 0;
      const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
      const int pred[5] = {0, a, b, (a + b) / 2, pa <= pb && pa <= pc ? a : pb <= pc ? b : c};
      EXPECT_LT(in[0], 5);
      px[y * row + i] = std::uint8_t(in[1 + i] + pred[in[0] % 5]);
    }
  }
  return px;
}

// A rendering's kind of picture: a background of one colour around a shaded disc with noise,
// and values that test the rounding and clamping in the first rows.
std::vector<float> picture(int w, int h) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-2.0f, 258.0f);
  std::vector<float> rgb(std::size_t(w) * std::size_t(h) * 3, 40.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float dx = float(x - w / 2), dy = float(y - h / 2), r = float(h) * 0.4f;
      if (dx * dx + dy * dy > r * r) continue;
      for (std::size_t c = 0; c < 3; ++c)
        rgb[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3 + c] =
            128.0f + 100.0f * dx / r + 20.0f * float(c) + 0.1f * u(rng);
    }
  const float special[] = {-3.0f,
                           -0.0f,
                           0.0f,
                           0.5f,
                           1.5f,
                           2.5f,
                           254.5f,
                           255.5f,
                           300.f,
                           7.4f,
                           7.6f,
                           0.49999997f,
                           1e-30f,
                           127.49999f,
                           std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity()};
  std::size_t i = 0;
  for (const float v : special) rgb[i++] = v;
  for (int k = 0; k <= 255 * 8 && i < rgb.size(); ++k) rgb[i++] = float(k) / 8.0f;  // halves
  for (; i < std::size_t(w) * 3 * 8; ++i) rgb[i] = u(rng);
  return rgb;
}

TEST(PngWrite, DecodesToTheRoundedLevelsWithAnyNumberOfThreads) {
  TempDir dir;
  const int w = 301, h = 403;  // four bands
  const std::vector<float> rgb = picture(w, h);
  std::vector<std::uint8_t> want(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i)
    want[i] = rgb[i] >= 0.0f ? std::uint8_t(std::lround(std::min(rgb[i], 255.0f))) : 0;
  const int threads = omp_get_max_threads();
  std::vector<std::uint8_t> first;
  for (const int t : {1, 2, 5}) {
    omp_set_num_threads(t);
    const fs::path path = dir / fmt::format("a{}.png", t);
    btfgmm::write_png(path, w, h, rgb);
    const std::vector<std::uint8_t> bytes = btfgmm::read_whole_file(path, "picture");
    EXPECT_EQ(decode_with_zlib(bytes, w, h), want) << t << " threads";
    if (first.empty()) first = bytes;
    EXPECT_EQ(bytes, first) << "the file's bytes differ with " << t << " threads";
    const btfgmm::Image img = btfgmm::read_image(path);
    ASSERT_EQ(img.rgb.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i)
      ASSERT_EQ(img.rgb[i], float(want[i])) << "value " << i << " with " << t << " threads";
  }
  omp_set_num_threads(threads);
}

TEST(PngWrite, OneRowAndOnePixel) {
  TempDir dir;
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{5, 1}, std::pair{1, 40}}) {
    std::vector<float> rgb(std::size_t(w) * std::size_t(h) * 3);
    for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float((i * 37) % 256);
    btfgmm::write_png(dir / "p.png", w, h, rgb);
    const btfgmm::Image img = btfgmm::read_image(dir / "p.png");
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    EXPECT_EQ(img.rgb, rgb);
    fs::remove(dir / "p.png");
  }
}

}  // namespace
