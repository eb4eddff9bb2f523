// The UTIA writer: one folder per view, one image per light in it.
#include "btfgmm/io/utia.hpp"

#include <fmt/format.h>

#include <mutex>
#include <span>
#include <system_error>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/image_names.hpp"
#include "io/angle_names.hpp"
#include "io/parallel_each.hpp"

namespace btfgmm {

namespace fs = std::filesystem;
using detail::angles;

void write_utia(const Btf& btf, const fs::path& folder, std::optional<ImageFormat> format,
                const std::function<void(double fraction)>& progress) {
  const ImageFormat f =
      format.value_or(btf.format() == SampleFormat::kHdr ? ImageFormat::kExr : ImageFormat::kPng);
  if (f == ImageFormat::kJpeg)
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write {} as JPEG (lossy); write PNG or EXR", folder.string()));
  const char* ext = f == ImageFormat::kExr ? ".exr" : ".png";
  const std::size_t nv = btf.views().size();
  std::vector<fs::path> view_dirs(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    view_dirs[v] = folder / angles(btf.views()[v], "tv", "pv", '_');
    std::error_code ec;
    fs::create_directories(view_dirs[v], ec);
    if (ec)
      throw Error(Error::Kind::kIo, fmt::format("cannot create the folder {}: {}",
                                                view_dirs[v].string(), ec.message()));
  }
  std::mutex progress_mutex;
  std::size_t written = 0;
  detail::parallel_each<detail::NoState>(
      btf.image_count(), [] { return detail::NoState{}; },
      [&](detail::NoState&, std::size_t i) {
        const std::size_t l = i / nv, v = i % nv;
        const fs::path p = view_dirs[v] / (utia_image_stem(btf.lights()[l], btf.views()[v]) + ext);
        const std::span<const float> px(btf.image(l, v), btf.image_floats());
        if (f == ImageFormat::kExr)
          write_exr(p, btf.width(), btf.height(), px);
        else
          write_png(p, btf.width(), btf.height(), px);
        if (progress) {
          const std::lock_guard<std::mutex> lock(progress_mutex);
          progress(double(++written) / double(btf.image_count()));
        }
      });
}

}  // namespace btfgmm
