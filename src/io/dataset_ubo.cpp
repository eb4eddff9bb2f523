// A Bonn .btf file as a data set (io/ubo_btf.hpp): its directions as the file lists them, its
// images decoded per tile from the tile's factors, one image per thread at a time.
#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/ubo_btf.hpp"
#include "io/parallel_each.hpp"

namespace btfgmm {
namespace {

std::string components_text(const UboBtfHeader& h) {
  std::vector<std::string> parts;
  for (std::uint32_t k : h.components) parts.push_back(std::to_string(k));
  return h.kind == UboKind::kDfmf ? fmt::format("{} per channel ({})", fmt::join(parts, ", "),
                                                fmt::join(h.channel_names, ", "))
                                  : fmt::format("{} (the three channels together)", parts.at(0));
}

// The details `info` shows of a .btf file, in order.
std::vector<std::pair<std::string, std::string>> ubo_details(const UboBtfHeader& h) {
  std::vector<std::pair<std::string, std::string>> d;
  d.emplace_back("format",
                 h.kind == UboKind::kDfmf
                     ? fmt::format("DFMF, decorrelated full matrix factorisation ({})", h.signature)
                     : fmt::format("FMF, full matrix factorisation ({}, extended "
                                   "header version {})",
                                   h.signature, h.fmf_header_version));
  d.emplace_back("components", components_text(h));
  d.emplace_back("scalars", h.scalar_bytes == 2 ? "half floats"
                                                : fmt::format("{}-byte floats", h.scalar_bytes));
  if (h.kind == UboKind::kDfmf)
    d.emplace_back("colour model",
                   fmt::format("{} ({})", h.colour_model, ubo_colour_model_name(h.colour_model)));
  else
    d.emplace_back("range", h.dynamic_range_reduction == 0 ? "linear (no reduction)"
                                                           : "log(value + 1e-5) stored");
  d.emplace_back("cosine",
                 h.cosine_in_data ? "in the data (divided out when decoding)" : "not in the data");
  d.emplace_back("metadata", fmt::format("version {}", h.version));
  d.emplace_back("setup", h.measurement_setup);
  d.emplace_back("sensor", h.image_sensor);
  d.emplace_back("light source", h.light_source);
  d.emplace_back("ppmm", fmt::format("{}", h.ppmm));
  d.emplace_back("rgb scale", fmt::format("{} {} {} (stored, not applied)", h.rgb_scale[0],
                                          h.rgb_scale[1], h.rgb_scale[2]));
  d.emplace_back("rotations", std::to_string(h.rotations));
  d.emplace_back("xml", fmt::format("{} bytes", h.xml.size()));
  if (h.height_map_width > 0)
    d.emplace_back("height map", fmt::format("{} x {}", h.height_map_width, h.height_map_height));
  return d;
}

}  // namespace

BtfSource BtfSource::open_ubo(const std::filesystem::path& path) {
  auto ubo = std::make_shared<const UboBtf>(UboBtf::open(path));
  const UboBtfHeader& h = ubo->header();
  BtfSource src;
  BtfInfo& info = src.info_;
  info.path = path;
  info.layout = Layout::kUboBtf;
  info.lights = h.lights;
  info.views = h.views;
  info.width = h.width;
  info.height = h.height;
  info.format = SampleFormat::kHdr;
  info.image_format = ImageFormat::kExr;
  info.file_bytes = h.file_bytes;
  info.details = ubo_details(h);
  const std::size_t nv = h.views.size();
  src.names_.resize(h.lights.size() * nv);
  for (std::size_t i = 0; i < src.names_.size(); ++i)
    src.names_[i] = utia_image_stem(h.lights[i / nv], h.views[i % nv]);
  src.ubo_ = std::move(ubo);
  return src;
}

void BtfSource::read_ubo_tiles(const Tile& tile, std::size_t first, std::size_t last,
                               const TileSink& take) const {
  const UboBtf& ubo = *ubo_;
  limits::check_memory(ubo.tile_bytes(tile),
                       fmt::format("the factors of a {}x{} tile of {}", tile.width, tile.height,
                                   info_.path.string()),
                       fmt::format("give a smaller tile ({} X,Y,W,H)", option_name("tile")));
  const UboTileFactors factors = ubo.load_tile(tile);
  const std::size_t nv = info_.views.size();
  const std::size_t floats = std::size_t(factors.tile.width) * factors.tile.height * 3;
  detail::parallel_each<std::vector<float>>(
      last - first, [&] { return std::vector<float>(floats); },
      [&](std::vector<float>& rgb, std::size_t k) {
        const std::size_t i = first + k;
        ubo.decode(factors, i / nv, i % nv, rgb);
        take(i, rgb);
      });
}

}  // namespace btfgmm
