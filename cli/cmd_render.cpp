// btfgmm render: the material on a 3D object, from a model or from the measured data, or
// both side by side as the paper's Fig. 3.
#include <fmt/format.h>
#include <omp.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/tile.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/render/render.hpp"
#include "btfgmm/render/scene.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "provenance_text.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

// ---- render ------------------------------------------------------------------------------

struct RenderArguments {
  std::string input, compare, tile, out;
  btfgmm::SceneText scene;  // the mesh, the camera and the light
  std::string size = "800x800", background = "40,40,40";
  double repeat = 4.0, exposure = 0.0, tolerance = 0.1;
  double difference_scale = 10.0;
  int threads = 0;
  bool overwrite = false, json = false, quiet = false, force = false;
};

// The figure's caption with the options it names spelled as flags.
btfgmm::FigureCaption command_line_caption(btfgmm::FigureCaption c) {
  for (std::string& line : c.scene) line = command_line_text(line);
  return c;
}

// The data a --tile asks for, or `fallback` when none is given.
btfgmm::Btf load_data(const std::string& path, const std::string& tile,
                      const btfgmm::Tile& fallback, bool quiet) {
  btfgmm::BtfSource src = btfgmm::BtfSource::open(path);
  const btfgmm::Tile t = tile.empty() ? fallback : tile_option(src, tile, quiet);
  return src.load(t);
}

// --compare's data: the tile --tile asks for (the model's own by default), checked against the
// data the model records (its own tile, read for that where --tile asks for another).
btfgmm::Btf load_compared_data(const btfgmm::Representation& model, const RenderArguments& o,
                               btfgmm::DataMatch& match) {
  const btfgmm::BtfSource given = btfgmm::BtfSource::open(o.compare);
  // A model of a made tile is checked against that tile made again from the data.
  const btfgmm::BtfSource fitted = btfgmm::fitted_source(given, model.provenance());
  const btfgmm::BtfInfo& info = fitted.info();
  const btfgmm::Tile own = model.frame().origin;
  btfgmm::BtfSource shown = o.tile.empty() ? fitted : given;
  const btfgmm::Tile t = o.tile.empty() ? own : tile_option(shown, o.tile, o.quiet);
  btfgmm::Btf data = shown.load(t);
  const bool quiet = o.quiet || o.json;
  if (own.x + own.width > info.width || own.y + own.height > info.height) {
    match = enforce_data_check(
        {btfgmm::DataMatch::kOtherContent,
         fmt::format("'{}' is not the data '{}' was fitted to: the model records {}, outside "
                     "the {}x{} images of '{}'",
                     o.compare, o.input, btfgmm::describe_source(model.provenance(), own),
                     info.width, info.height, o.compare)},
        o.force, quiet, "render");
    return data;
  }
  const btfgmm::DataSource source{o.compare, given.info().width, given.info().height};
  const bool same = o.tile.empty() || (t == own && !shown.pixel_map() && !fitted.pixel_map());
  match = enforce_data_check(
      btfgmm::check_fitted_data(model, o.input, same ? data : fitted.load(own), source), o.force,
      quiet, "render");
  return data;
}

nlohmann::json stats_json(const btfgmm::Rendering& r) {
  return {{"geometry_seconds", r.geometry_seconds},
          {"shading_seconds", r.stats.seconds},
          {"points", r.stats.points},
          {"component_evaluations_nominal", r.stats.nominal},
          {"component_evaluations", r.stats.evaluated}};
}

// What is rendered: a model, measured data, or both (--compare), and how the data matches
// the model's provenance.
struct RenderInputs {
  std::shared_ptr<const btfgmm::Representation> model;
  std::optional<btfgmm::Btf> data;
  btfgmm::DataMatch match = btfgmm::DataMatch::kSame;
};

// The input and --compare, --tile as they may be combined, refused before any work otherwise.
void check_render_inputs(const RenderArguments& o, bool model_input) {
  if (!o.compare.empty() && !model_input)
    throw Error(Error::Kind::kArgument,
                fmt::format("--compare needs a model as the input, and '{}' is not a model file; "
                            "give the .btfgmm first and the data after --compare",
                            o.input));
  if (model_input && o.compare.empty() && !o.tile.empty())
    throw Error(Error::Kind::kArgument,
                "--tile chooses a tile of measured data; a model renders its own tile (give "
                "--tile with --compare to compare with another tile of the data)");
}

RenderInputs load_render_inputs(const RenderArguments& o, bool model_input) {
  RenderInputs in;
  if (!model_input) {
    in.data = load_data(o.input, o.tile, {}, o.quiet);
    return in;
  }
  in.model = btfgmm::load_representation(o.input);
  if (o.compare.empty()) return in;
  in.data = load_compared_data(*in.model, o, in.match);
  const btfgmm::ModelFrame& f = in.model->frame();
  if (in.data->width() != f.width || in.data->height() != f.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("the data tile is {}x{} pixels and the model's {}x{}: compare the "
                            "model with the tile it was fitted to (the default) or one of "
                            "its size",
                            in.data->width(), in.data->height(), f.width, f.height));
  return in;
}

// The model rendering's figures: into `j`, and a line of the summary.
std::string model_summary(const btfgmm::Representation& model, const btfgmm::Rendering& img,
                          double geometry_seconds, double tolerance, nlohmann::json& j) {
  const auto& st = img.stats;
  j["model"] = stats_json(img);
  j["model"]["method"] = std::string(model.method());
  j["model"]["size"] = model.size_text();
  if (model.method() != btfgmm::kMixtureMethod)
    return fmt::format("model ({} {}): {} lit pixels in {:.3f} s + geometry {:.3f} s\n",
                       model.method(), model.size_text(), st.points, st.seconds, geometry_seconds);
  j["model"]["components"] = std::size_t(model.size_order());
  return fmt::format(
      "model ({}): {} in {:.3f} s + geometry {:.3f} s; {:.0f} M component evaluations "
      "nominal ({:.2f} G/s), {:.0f} M evaluated after skipping (tolerance {:g} levels)\n",
      model.size_text(), fmt::format("{} lit pixels", st.points), st.seconds, geometry_seconds,
      double(st.nominal) * 1e-6,
      double(st.nominal) * 1e-9 / std::max(st.seconds + geometry_seconds, 1e-9),
      double(st.evaluated) * 1e-6, tolerance);
}

// The figure data | model | difference written, its metrics into `j`; the summary's lines.
std::string write_comparison(const RenderArguments& o, const RenderInputs& in,
                             const btfgmm::RenderSettings& s, const btfgmm::Rendering& data_img,
                             const btfgmm::Rendering& model_img, nlohmann::json& j) {
  const btfgmm::RenderComparison c = btfgmm::compare_renderings(data_img, model_img);
  const btfgmm::Image fig = btfgmm::comparison_figure(
      data_img, model_img, c, o.difference_scale,
      command_line_caption(btfgmm::figure_caption(o.scene, s, *in.model)));
  btfgmm::write_picture(o.out, fig.width, fig.height, fig.rgb);
  j["data_match"] = std::string(btfgmm::to_string(in.match));
  j["rmse"] = c.rmse;
  j["psnr_db"] = c.psnr;
  j["ssim"] = c.ssim;
  j["object_pixels"] = c.pixels;
  j["pixelwise_meaningful"] = !in.model->synthesises();
  std::string summary = fmt::format(
      "data | model | {:g}x difference: RMSE {:.2f}, PSNR {:.2f} dB, SSIM {:.3f} "
      "over {} object pixels\n",
      o.difference_scale, c.rmse, c.psnr, c.ssim, c.pixels);
  if (in.model->synthesises()) summary += fmt::format("{}\n", btfgmm::synthesis_note());
  return summary;
}

void run_render(const RenderArguments& o) {
  if (o.threads > 0) omp_set_num_threads(o.threads);
  btfgmm::output_image_format(o.out);  // a format btfgmm writes, before any work
  check_output_file(o.out, o.overwrite);
  const bool model_input = is_model_path(o.input);
  check_render_inputs(o, model_input);
  const btfgmm::RenderSettings s = btfgmm::render_settings(
      o.size, o.background, o.repeat, o.exposure, o.tolerance, !o.compare.empty());
  const btfgmm::Scene scene = btfgmm::build_scene(o.scene);
  const auto t0 = Clock::now();
  const RenderInputs in = load_render_inputs(o, model_input);
  const double load_seconds = seconds_since(t0);
  const btfgmm::ModelFrame* frame = in.model ? &in.model->frame() : nullptr;
  const btfgmm::SurfaceBuffer surface = btfgmm::rasterize(
      scene.mesh, scene.camera, scene.light, s, frame ? frame->width : in.data->width(),
      frame ? frame->height : in.data->height());
  const btfgmm::SampleFormat format = frame ? frame->format : in.data->format();
  std::optional<btfgmm::Rendering> model_img, data_img;
  if (in.model)
    model_img =
        btfgmm::render(surface, btfgmm::RepresentationEvaluator(in.model, s.tolerance), s, format);
  if (in.data) data_img = btfgmm::render(surface, btfgmm::DataEvaluator(*in.data), s, format);

  nlohmann::json j;
  j["output"] = o.out;
  j["width"] = s.width;
  j["height"] = s.height;
  j["lit_pixels"] = surface.points.size();
  j["load_seconds"] = load_seconds;
  std::string summary;
  if (model_img) summary += model_summary(*in.model, *model_img, surface.seconds, s.tolerance, j);
  if (data_img) {
    j["data"] = stats_json(*data_img);
    summary += fmt::format("data ({}x{} tile): {:.3f} s + geometry {:.3f} s\n", in.data->width(),
                           in.data->height(), data_img->stats.seconds, surface.seconds);
  }
  if (model_img && data_img) {
    summary += write_comparison(o, in, s, *data_img, *model_img, j);
  } else {
    const btfgmm::Rendering& r = model_img ? *model_img : *data_img;
    btfgmm::write_picture(o.out, r.width, r.height, r.rgb);
  }
  if (o.json) {
    std::cout << j.dump() << "\n";
  } else if (!o.quiet) {
    fmt::print(stderr, "{}wrote {}\n", summary, o.out);
  }
}

}  // namespace

void register_render_command(CLI::App& app, Commands& commands) {
  auto ro = std::make_shared<RenderArguments>();
  auto* r = app.add_subcommand(
      "render",
      "Render the material on a 3D object from a model or from measured data; with --compare, "
      "data | model | difference side by side (the paper's Fig. 3)");
  r->add_option("input", ro->input, "A .btfgmm model, or a BTF folder / Bonn .zip")->required();
  r->add_option("--compare", ro->compare,
                "The measured BTF to render next to the model (its tile: the model's own, or "
                "--tile)");
  r->add_option("--tile", ro->tile,
                fmt::format("X,Y,W,H of the measured data to render, or {}", kAutoTileHelp));
  r->add_option("--mesh", ro->scene.mesh,
                "sphere, cylinder, cloth, plane, or a Wavefront .obj file")
      ->capture_default_str();
  r->add_option("--light", ro->scene.light,
                "Directional light THETA,PHI in degrees (world, z up; theta 0-180)")
      ->capture_default_str();
  r->add_option("--point-light", ro->scene.point_light, "A point light at X,Y,Z instead");
  r->add_option("--intensity", ro->scene.intensity,
                "Light intensity (1: as measured; a point light: at the object's centre)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  r->add_option("--camera", ro->scene.camera, "Orbit camera THETA,PHI in degrees around the object")
      ->capture_default_str();
  r->add_option("--eye", ro->scene.eye, "Look-at camera: the eye at X,Y,Z (instead of --camera)");
  r->add_option("--target", ro->scene.target, "The point looked at (default: the object's centre)");
  r->add_option("--up", ro->scene.up, "Look-at camera: the up direction")->capture_default_str();
  r->add_option("--fov", ro->scene.fov, "Vertical field of view, degrees")
      ->check(CLI::Range(1.0, 170.0))
      ->capture_default_str();
  r->add_option("--repeat", ro->repeat, "Tiles across one unit of texture coordinates")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  r->add_option("--size", ro->size, "Image size WxH pixels (a figure is three of them wide)")
      ->capture_default_str();
  r->add_option("--exposure", ro->exposure, "Exposure in stops (values times 2^EV)")
      ->capture_default_str();
  r->add_option("--background", ro->background, "Background R,G,B levels")->capture_default_str();
  r->add_option("--tolerance", ro->tolerance,
                "Largest colour error (levels) that skipping negligible components may cause; 0 "
                "evaluates all")
      ->check(CLI::Range(0.0, 255.0))
      ->capture_default_str();
  r->add_option("--difference-scale", ro->difference_scale, "Scale of the difference image")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  r->add_option("--threads", ro->threads, "Threads (0: all cores)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  r->add_option("-o,--output", ro->out,
                "The picture to write, in the format its extension names: .png, .jpg (or .jpeg; "
                "quality 95) or .exr (linear values, the sRGB levels decoded)")
      ->required();
  r->add_flag("--overwrite", ro->overwrite, "Replace an existing file");
  r->add_flag("--force", ro->force,
              "With --compare: render even where the model's provenance records other data");
  r->add_flag("--json", ro->json, "Timings and metrics as one JSON object on stdout");
  r->add_flag("-q,--quiet", ro->quiet, "No summary on stderr");
  commands.push_back({r, [ro] { run_render(*ro); }});
}

}  // namespace btfgmm::cli
