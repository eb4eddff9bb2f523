// btfgmm info: a BTF (folder or Bonn .zip) or a model file described.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "provenance_text.hpp"

namespace btfgmm::cli {
namespace {

void info_btf(const std::string& path, bool json) {
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(path);
  const btfgmm::BtfInfo& i = src.info();
  const std::uint64_t images = i.lights.size() * i.views.size();
  const double raw8 = double(images) * i.width * i.height * 3.0;
  if (json) {
    nlohmann::json j;
    j["path"] = path;
    j["kind"] = "btf";
    j["layout"] = btfgmm::to_string(i.layout);
    j["lights"] = i.lights.size();
    j["views"] = i.views.size();
    j["images"] = images;
    j["width"] = i.width;
    j["height"] = i.height;
    j["bit_depth"] = btfgmm::to_string(i.format);
    j["image_format"] = btfgmm::to_string(i.image_format);
    j["file_bytes"] = i.file_bytes;
    j["raw_bytes_8bit"] = std::uint64_t(raw8);
    j["ignored_files"] = i.ignored_files;
    j["light_directions"] = set_json(i.lights);
    j["view_directions"] = set_json(i.views);
    for (const auto& [k, v] : i.details) j["details"][k] = v;
    std::cout << json_text(j);
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  layout       {}\n", btfgmm::to_string(i.layout));
  fmt::print("  lights       {}\n", describe_set(i.lights));
  fmt::print("  views        {}\n", describe_set(i.views));
  fmt::print("  images       {} ({} x {})\n", images, i.lights.size(), i.views.size());
  fmt::print("  image size   {} x {} pixels, RGB\n", i.width, i.height);
  const bool factors = i.layout == btfgmm::Layout::kUboBtf;  // no image files
  fmt::print("  bit depth    {} ({})\n", btfgmm::to_string(i.format),
             factors ? "decoded from the factors" : btfgmm::to_string(i.image_format));
  fmt::print("  bytes        {} in files; {} as 8-bit RGB (W*H*ni*nv*3 = {:.0f})\n",
             human_bytes(double(i.file_bytes)), human_bytes(raw8), raw8);
  if (i.ignored_files > 0)
    fmt::print("  ignored      {} files that are not images\n", i.ignored_files);
  for (const auto& [k, v] : i.details) fmt::print("  {:<12} {}\n", k, v);
  if (!factors) fmt::print("  first image  {}\n", src.image_name(0, 0));
}

void info_model(const std::string& path, bool json) {
  const std::vector<std::uint8_t> file = btfgmm::read_whole_file(path, "model file");
  const auto r = btfgmm::read_representation(file, path);
  const std::uint32_t version = btfgmm::open_model_file(file, path).version;
  const btfgmm::ModelFrame& m = r->frame();
  const std::uint64_t bytes = file.size();
  const std::size_t requested =
      r->method() == btfgmm::kMixtureMethod
          ? dynamic_cast<const btfgmm::GaussianMixture&>(*r).model().settings.components
          : 0;
  if (json) {
    nlohmann::json j;
    j["path"] = path;
    j["kind"] = "model";
    j["format_version"] = version;
    j["provenance"] = provenance_json(r->provenance(), requested);
    j["tile"] = {m.origin.x, m.origin.y, m.width, m.height};
    j["lights"] = m.lights.size();
    j["views"] = m.views.size();
    j["bit_depth"] = btfgmm::to_string(m.format);
    put_model_json(j, *r);
    j["file_bytes"] = bytes;
    j["compression_ratio_paper"] = r->paper_ratio();
    j["compression_ratio_file"] = r->file_ratio(bytes);
    std::cout << json_text(j);
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  model        btfgmm format {}\n", version);
  fmt::print("  tile         {}x{} pixels at ({}, {}) of the source, {} data\n", m.width, m.height,
             m.origin.x, m.origin.y, btfgmm::to_string(m.format));
  fmt::print("  lights       {}\n", describe_set(m.lights));
  fmt::print("  views        {}\n", describe_set(m.views));
  print_model_lines(*r);
  print_provenance_lines(r->provenance(), m.origin);
  fmt::print("  file         {} bytes ({})\n", bytes, human_bytes(double(bytes)));
  fmt::print(
      "  compression  1:{:.1f} by the paper's count (Table 2), 1:{:.1f} by the file's "
      "bytes\n",
      r->paper_ratio(), r->file_ratio(bytes));
}

}  // namespace

void register_info_command(CLI::App& app, Commands& commands) {
  auto info_path = std::make_shared<std::string>();
  auto info_json = std::make_shared<bool>(false);
  auto* inf = app.add_subcommand(
      "info", "Describe a BTF (folder, Bonn .zip or Bonn .btf file) or a model file");
  inf->add_option("path", *info_path, "A BTF folder, .zip or .btf file, or a .btfgmm model")
      ->required();
  inf->add_flag("--json", *info_json, "One JSON object for scripts");

  commands.push_back({inf, [info_path, info_json] {
                        is_model_path(*info_path) ? info_model(*info_path, *info_json)
                                                  : info_btf(*info_path, *info_json);
                      }});
}

}  // namespace btfgmm::cli
