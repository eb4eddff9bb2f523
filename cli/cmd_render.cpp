// btfgmm render (the material on a 3D object, from a model or from the measured data, or
// both side by side as the paper's Fig. 3) and btfgmm tile (the most seamless tile).
#include <fmt/format.h>
#include <omp.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/tile.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/render/render.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "provenance_text.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

// ---- render ------------------------------------------------------------------------------

struct RenderOptions {
  std::string input, compare, tile, mesh = "sphere", out;
  std::string light = "45,30", point_light, camera = "60,0", eye, target, up = "0,0,1";
  std::string size = "800x800", background = "40,40,40";
  double intensity = 1.0, fov = 30.0, repeat = 4.0, exposure = 0.0, tolerance = 0.1;
  double difference_scale = 10.0;
  int threads = 0;
  bool overwrite = false, json = false, quiet = false, force = false;
};

// A synthesis model (the texture models) makes new texture with the data's statistics: its
// pixels are not the data's, so the pixel-wise figures of --compare measure nothing of it.
constexpr const char* kSynthesisNote =
    "synthesis: new texture with the data's statistics, the pixel-wise RMSE, PSNR and SSIM are "
    "NOT meaningful (btfgmm compare measures its statistics)";

// What the comparison figure states besides its metrics: the model and the scene (and, for a
// synthesis model, that the pixel-wise figures mean nothing).
btfgmm::FigureCaption figure_caption(const RenderOptions& o, const btfgmm::Representation& model) {
  const auto angles = [](const std::string& dir) {
    const auto comma = dir.find(',');
    return fmt::format("θ {}° φ {}°", dir.substr(0, comma), dir.substr(comma + 1));
  };
  btfgmm::FigureCaption c;
  c.model = fmt::format("{}, {}", model.method(), model.size_text());
  const std::string light =
      o.point_light.empty() ? "light " + angles(o.light) : "point light at (" + o.point_light + ")";
  const std::string camera =
      o.eye.empty() ? "camera " + angles(o.camera) : "camera at (" + o.eye + ")";
  c.scene.push_back(fmt::format("{} · {} · mesh {} · tile repeated {:g}× · exposure {:+g} EV",
                                light, camera, fs::path(o.mesh).filename().string(), o.repeat,
                                o.exposure));
  c.scene.push_back(
      fmt::format("model evaluated to {:g} levels (--tolerance); data interpolated "
                  "between measured directions",
                  o.tolerance));
  if (model.synthesises()) c.scene.push_back(kSynthesisNote);
  return c;
}

// A world direction "THETA,PHI": theta from +z in [0, 180] (a light or a camera may be
// below the object), phi from +x toward +y.
btfgmm::Direction parse_world_direction(const std::string& text, const std::string& option) {
  const auto v = parse_numbers(text, option, 2, "45,30 (theta,phi in degrees)");
  if (v[0] < 0.0 || v[0] > 180.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': theta {} is not in [0, 180] degrees (0: from above, 180: "
                            "from below)",
                            option, text, v[0]));
  double phi = std::fmod(v[1], 360.0);
  if (phi < 0) phi += 360.0;
  return {v[0], phi};
}

btfgmm::Vec3 parse_vec3(const std::string& text, const std::string& option) {
  const auto v = parse_numbers(text, option, 3, "0,0,4 (x,y,z)");
  return {v[0], v[1], v[2]};
}

// The data a --tile asks for, or `fallback` when none is given.
btfgmm::Btf load_data(const std::string& path, const std::string& tile,
                      const btfgmm::Tile& fallback, bool quiet) {
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(path);
  const btfgmm::Tile t = tile.empty() ? fallback : tile_option(src, tile, quiet);
  return src.load(t);
}

bool same_tile(const btfgmm::Tile& a, const btfgmm::Tile& b) {
  return a.x == b.x && a.y == b.y && a.width == b.width && a.height == b.height;
}

// --compare's data: the tile --tile asks for (the model's own by default), checked against the
// data the model records (its own tile, read for that where --tile asks for another).
btfgmm::Btf load_compared_data(const btfgmm::Representation& model, const RenderOptions& o,
                               btfgmm::DataMatch& match) {
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.compare);
  const btfgmm::BtfInfo& info = src.info();
  const btfgmm::Tile own = model.frame().origin;
  const btfgmm::Tile t = o.tile.empty() ? own : tile_option(src, o.tile, o.quiet);
  btfgmm::Btf data = src.load(t);
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
  const btfgmm::DataSource source{o.compare, info.width, info.height};
  match = enforce_data_check(
      btfgmm::check_fitted_data(model, o.input, same_tile(t, own) ? data : src.load(own), source),
      o.force, quiet, "render");
  return data;
}

nlohmann::json stats_json(const btfgmm::Rendering& r) {
  return {{"geometry_seconds", r.geometry_seconds},
          {"shading_seconds", r.stats.seconds},
          {"points", r.stats.points},
          {"component_evaluations_nominal", r.stats.nominal},
          {"component_evaluations", r.stats.evaluated}};
}

void run_render(const RenderOptions& o) {
  if (o.threads > 0) omp_set_num_threads(o.threads);
  btfgmm::output_image_format(o.out);  // a format btfgmm writes, before any work
  check_output_file(o.out, o.overwrite);
  const bool model_input = is_model_path(o.input);
  if (!o.compare.empty() && !model_input)
    throw Error(Error::Kind::kArgument,
                fmt::format("--compare needs a model as the input, and '{}' is not a model file; "
                            "give the .btfgmm first and the data after --compare",
                            o.input));
  if (model_input && o.compare.empty() && !o.tile.empty())
    throw Error(Error::Kind::kArgument,
                "--tile chooses a tile of measured data; a model renders its own tile (give "
                "--tile with --compare to compare with another tile of the data)");

  btfgmm::RenderSettings s;
  std::tie(s.width, s.height) = parse_size(o.size);
  // Before any allocation: a rendering takes about 100 bytes a pixel (surface points, colours,
  // the PNG; measured on a sphere at 2048 x 2048), 130 with --compare.
  limits::check_memory(double(s.width) * s.height * (o.compare.empty() ? 100.0 : 130.0),
                       fmt::format("rendering {}x{} pixels", s.width, s.height),
                       "give a smaller --size");
  s.repeat = o.repeat;
  s.exposure = o.exposure;
  s.tolerance = o.tolerance;
  const auto bg = parse_numbers(o.background, "--background", 3, "40,40,40 (levels 0-255)");
  s.background = {float(bg[0]), float(bg[1]), float(bg[2])};

  const btfgmm::Mesh mesh = btfgmm::make_mesh(o.mesh);
  btfgmm::Camera camera;
  if (!o.eye.empty()) {
    camera.eye = parse_vec3(o.eye, "--eye");
    camera.target = o.target.empty() ? mesh.center() : parse_vec3(o.target, "--target");
    camera.up = parse_vec3(o.up, "--up");
    camera.fov_deg = o.fov;
  } else {
    camera = btfgmm::Camera::orbit(
        parse_world_direction(o.camera, "--camera"), mesh.radius(),
        o.target.empty() ? mesh.center() : parse_vec3(o.target, "--target"), o.fov);
  }
  btfgmm::Light light;
  if (!o.point_light.empty()) {
    const btfgmm::Vec3 p = parse_vec3(o.point_light, "--point-light");
    const btfgmm::Vec3 c = mesh.center();
    const double d2 =
        (p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z);
    // As bright at the object's centre as a directional light of the same intensity.
    light = btfgmm::Light::point(p, o.intensity * d2);
  } else {
    light = btfgmm::Light::directional(parse_world_direction(o.light, "--light"), o.intensity);
  }

  const auto t0 = Clock::now();
  std::shared_ptr<const btfgmm::Representation> model;
  std::optional<btfgmm::Btf> data;
  btfgmm::DataMatch match = btfgmm::DataMatch::kSame;
  if (model_input) {
    model = btfgmm::load_representation(o.input);
    if (!o.compare.empty()) {
      data = load_compared_data(*model, o, match);
      if (data->width() != model->frame().width || data->height() != model->frame().height)
        throw Error(Error::Kind::kArgument,
                    fmt::format("the data tile is {}x{} pixels and the model's {}x{}: compare the "
                                "model with the tile it was fitted to (the default) or one of "
                                "its size",
                                data->width(), data->height(), model->frame().width,
                                model->frame().height));
    }
  } else {
    data = load_data(o.input, o.tile, {}, o.quiet);
  }
  const double load_seconds = seconds_since(t0);
  const int tw = model ? model->frame().width : data->width(),
            th = model ? model->frame().height : data->height();
  const btfgmm::SampleFormat format = model ? model->frame().format : data->format();
  const btfgmm::SurfaceBuffer surface = btfgmm::rasterize(mesh, camera, light, s, tw, th);

  std::optional<btfgmm::Rendering> model_img, data_img;
  if (model) {
    const btfgmm::RepresentationEvaluator ev(model, s.tolerance);
    model_img = btfgmm::render(surface, ev, s, format);
  }
  if (data) {
    const btfgmm::DataEvaluator ev(*data);
    data_img = btfgmm::render(surface, ev, s, format);
  }

  nlohmann::json j;
  j["output"] = o.out;
  j["width"] = s.width;
  j["height"] = s.height;
  j["lit_pixels"] = surface.points.size();
  j["load_seconds"] = load_seconds;
  std::string summary;
  if (model_img) {
    const auto& st = model_img->stats;
    j["model"] = stats_json(*model_img);
    j["model"]["method"] = std::string(model->method());
    j["model"]["size"] = model->size_text();
    if (model->method() == btfgmm::kMixtureMethod) {
      j["model"]["components"] = std::size_t(model->size_order());
      summary += fmt::format(
          "model ({}): {} in {:.3f} s + geometry {:.3f} s; {:.0f} M component evaluations "
          "nominal ({:.2f} G/s), {:.0f} M evaluated after skipping (tolerance {:g} levels)\n",
          model->size_text(), fmt::format("{} lit pixels", st.points), st.seconds, surface.seconds,
          double(st.nominal) * 1e-6,
          double(st.nominal) * 1e-9 / std::max(st.seconds + surface.seconds, 1e-9),
          double(st.evaluated) * 1e-6, s.tolerance);
    } else {
      summary +=
          fmt::format("model ({} {}): {} lit pixels in {:.3f} s + geometry {:.3f} s\n",
                      model->method(), model->size_text(), st.points, st.seconds, surface.seconds);
    }
  }
  if (data_img) {
    j["data"] = stats_json(*data_img);
    summary += fmt::format("data ({}x{} tile): {:.3f} s + geometry {:.3f} s\n", data->width(),
                           data->height(), data_img->stats.seconds, surface.seconds);
  }
  if (model_img && data_img) {
    const btfgmm::RenderComparison c = btfgmm::compare_renderings(*data_img, *model_img);
    const btfgmm::Image fig = btfgmm::comparison_figure(
        *data_img, *model_img, c, o.difference_scale, figure_caption(o, *model));
    btfgmm::write_picture(o.out, fig.width, fig.height, fig.rgb);
    j["data_match"] = std::string(btfgmm::to_string(match));
    j["rmse"] = c.rmse;
    j["psnr_db"] = c.psnr;
    j["ssim"] = c.ssim;
    j["object_pixels"] = c.pixels;
    j["pixelwise_meaningful"] = !model->synthesises();
    summary += fmt::format(
        "data | model | {:g}x difference: RMSE {:.2f}, PSNR {:.2f} dB, SSIM {:.3f} "
        "over {} object pixels\n",
        o.difference_scale, c.rmse, c.psnr, c.ssim, c.pixels);
    if (model->synthesises()) summary += fmt::format("{}\n", kSynthesisNote);
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

// ---- tile --------------------------------------------------------------------------------

struct TileOptions {
  std::string input, size = "32x32";
  std::size_t images = 64, top = 1;
  bool json = false;
};

nlohmann::json candidate_json(const btfgmm::TileCandidate& c) {
  const btfgmm::Tile& t = c.tile;
  return {{"tile", {t.x, t.y, t.width, t.height}},
          {"score", c.score},
          {"seam_error", c.seam.total},
          {"left_right", c.seam.left_right},
          {"top_bottom", c.seam.top_bottom},
          {"rms_levels", c.seam.rms_levels}};
}

void run_tile(const TileOptions& o) {
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.input);
  btfgmm::TileSearchConfig c = btfgmm::parse_tile_search_size(o.size, "--size");
  c.images = o.images;
  c.top = o.top;
  const auto t0 = Clock::now();
  const btfgmm::TileSearchResult r = btfgmm::find_seamless_tile(src, c);
  const btfgmm::Tile& t = r.tile;
  if (o.json) {
    nlohmann::json j = candidate_json(r.ranked[0]);
    j["candidates"] = r.candidates;
    j["images"] = r.images;
    j["seconds"] = seconds_since(t0);
    if (o.top > 1) {
      j["ranked"] = nlohmann::json::array();
      for (const btfgmm::TileCandidate& k : r.ranked) j["ranked"].push_back(candidate_json(k));
    }
    std::cout << j.dump() << "\n";
    return;
  }
  if (o.top > 1) {
    fmt::print("{:>4}  {:<16} {:>7} {:>10} {:>10} {:>10}\n", "rank", "tile X,Y,W,H", "score",
               "seam error", "left-right", "top-bottom");
    for (std::size_t k = 0; k < r.ranked.size(); ++k) {
      const btfgmm::TileCandidate& e = r.ranked[k];
      fmt::print("{:>4}  {:<16} {:>7.3f} {:>10.3f} {:>10.3f} {:>10.3f}\n", k + 1,
                 fmt::format("{},{},{},{}", e.tile.x, e.tile.y, e.tile.width, e.tile.height),
                 e.score, e.seam.total, e.seam.left_right, e.seam.top_bottom);
    }
  } else {
    fmt::print("tile {},{},{},{}\n", t.x, t.y, t.width, t.height);
  }
  fmt::print(stderr,
             "seam error {:.3f} (left-right {:.3f}, top-bottom {:.3f}; 0 = repeats as the texture "
             "continues, 1 = as different as neighbouring pixels), {:.2f} levels RMS; {} "
             "candidates on {} images in {}\nfit it with: btfgmm fit {} --tile {},{},{},{} ...\n",
             r.seam.total, r.seam.left_right, r.seam.top_bottom, r.seam.rms_levels, r.candidates,
             r.images, human_seconds(seconds_since(t0)), o.input, t.x, t.y, t.width, t.height);
}

}  // namespace

void register_render_commands(CLI::App& app, Commands& commands) {
  auto ro = std::make_shared<RenderOptions>();
  auto* r = app.add_subcommand(
      "render",
      "Render the material on a 3D object from a model or from measured data; with --compare, "
      "data | model | difference side by side (the paper's Fig. 3)");
  r->add_option("input", ro->input, "A .btfgmm model, or a BTF folder / Bonn .zip")->required();
  r->add_option("--compare", ro->compare,
                "The measured BTF to render next to the model (its tile: the model's own, or "
                "--tile)");
  r->add_option("--tile", ro->tile,
                "X,Y,W,H of the measured data to render, or auto:WxH for the most seamless tile");
  r->add_option("--mesh", ro->mesh, "sphere, cylinder, cloth, plane, or a Wavefront .obj file")
      ->capture_default_str();
  r->add_option("--light", ro->light,
                "Directional light THETA,PHI in degrees (world, z up; theta 0-180)")
      ->capture_default_str();
  r->add_option("--point-light", ro->point_light, "A point light at X,Y,Z instead");
  r->add_option("--intensity", ro->intensity,
                "Light intensity (1: as measured; a point light: at the object's centre)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  r->add_option("--camera", ro->camera, "Orbit camera THETA,PHI in degrees around the object")
      ->capture_default_str();
  r->add_option("--eye", ro->eye, "Look-at camera: the eye at X,Y,Z (instead of --camera)");
  r->add_option("--target", ro->target, "The point looked at (default: the object's centre)");
  r->add_option("--up", ro->up, "Look-at camera: the up direction")->capture_default_str();
  r->add_option("--fov", ro->fov, "Vertical field of view, degrees")
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

  auto to = std::make_shared<TileOptions>();
  auto* t = app.add_subcommand(
      "tile", "Find the tile of a BTF that repeats with the least visible seams (for fit --tile)");
  t->add_option("input", to->input, "A BTF folder or Bonn .zip")->required();
  t->add_option("--size", to->size,
                "Tile size WxH; W and H may be ranges, e.g. 20-28x24. The tile chosen has the "
                "lowest score: its seam error times its aspect ratio (longer side / shorter "
                "side), so near-square tiles are preferred; ties go to the larger tile")
      ->capture_default_str();
  t->add_option("--images", to->images,
                "(light, view) images to judge the seams on, spread over all; 0: all")
      ->capture_default_str();
  t->add_option("--top", to->top,
                "List the N best tiles, the best position of each of the N best sizes, with "
                "their scores")
      ->check(CLI::Range(std::size_t(1), std::size_t(1000)))
      ->capture_default_str();
  t->add_flag("--json", to->json, "The result as one JSON object");
  commands.push_back({t, [to] { run_tile(*to); }});
}

}  // namespace btfgmm::cli
