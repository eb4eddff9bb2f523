// ssim_probe: RMSE, PSNR and SSIM of two images read from a text file, for the independent
// check against scikit-image (tests/ssim_check.py).
//
// Input: "WIDTH HEIGHT RANGE", then WIDTH * HEIGHT * 3 values of the original and as many of
// the reconstruction (row-major, RGB interleaved).
// Output: "window N", then "rmse R G B ALL", "psnr R G B ALL", "ssim R G B ALL", one per line.
#include <cstdio>
#include <fstream>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/measure/metrics.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: ssim_probe INPUT\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  int w = 0, h = 0;
  double range = 0;
  if (!(in >> w >> h >> range) || w < 1 || h < 1) {
    std::fprintf(stderr, "ssim_probe: cannot read the header of %s\n", argv[1]);
    return 2;
  }
  std::vector<float> a(std::size_t(w) * std::size_t(h) * 3), b(a.size());
  for (float& v : a) in >> v;
  for (float& v : b) in >> v;
  if (!in) {
    std::fprintf(stderr, "ssim_probe: %s is shorter than its header says\n", argv[1]);
    return 2;
  }
  try {
    const btfgmm::ImageQuality q = btfgmm::image_quality(a, b, w, h, range);
    std::printf("window %d\n", 2 * btfgmm::ssim_radius(w, h) + 1);
    std::printf("rmse %.17g %.17g %.17g %.17g\n", q.rmse_rgb[0], q.rmse_rgb[1], q.rmse_rgb[2],
                q.rmse);
    std::printf("psnr %.17g %.17g %.17g %.17g\n", q.psnr_db_rgb[0], q.psnr_db_rgb[1],
                q.psnr_db_rgb[2], q.psnr_db);
    std::printf("ssim %.17g %.17g %.17g %.17g\n", q.ssim_rgb[0], q.ssim_rgb[1], q.ssim_rgb[2],
                q.ssim);
  } catch (const btfgmm::Error& e) {
    std::fprintf(stderr, "ssim_probe: %s\n", e.what());
    return 1;
  }
  return 0;
}
