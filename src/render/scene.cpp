// A scene from its text (render/scene.hpp): the mesh, the camera, the light and the picture's
// settings, as `btfgmm render` takes them.
#include "btfgmm/render/scene.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <tuple>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/parse.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {
namespace {

Vec3 parse_point(const std::string& text, const char* field) {
  const auto v = parse_numbers(text, option_name(field), 3, "0,0,4 (x,y,z)");
  return {v[0], v[1], v[2]};
}

// The camera: at `eye` looking at the target, or on an orbit around it.
Camera scene_camera(const SceneText& t, const Mesh& mesh) {
  const Vec3 target = t.target.empty() ? mesh.center() : parse_point(t.target, "target");
  if (t.eye.empty())
    return Camera::orbit(parse_world_direction(t.camera, option_name("camera")), mesh.radius(),
                         target, t.fov);
  Camera camera;
  camera.eye = parse_point(t.eye, "eye");
  camera.target = target;
  camera.up = parse_point(t.up, "up");
  camera.fov_deg = t.fov;
  return camera;
}

// A directional light, or a point light as bright at the object's centre as a directional
// light of the same intensity (its intensity times the squared distance to the centre).
Light scene_light(const SceneText& t, const Mesh& mesh) {
  if (t.point_light.empty())
    return Light::directional(parse_world_direction(t.light, option_name("light")), t.intensity);
  const Vec3 p = parse_point(t.point_light, "point_light");
  const Vec3 c = mesh.center();
  const double d2 =
      (p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z);
  return Light::point(p, t.intensity * d2);
}

}  // namespace

Direction parse_world_direction(const std::string& text, const std::string& field) {
  const auto v = parse_numbers(text, field, 2, "45,30 (theta,phi in degrees)");
  if (v[0] < 0.0 || v[0] > 180.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': theta {} is not in [0, 180] degrees (0: from above, 180: "
                            "from below)",
                            field, text, v[0]));
  double phi = std::fmod(v[1], 360.0);
  if (phi < 0) phi += 360.0;
  return {v[0], phi};
}

Scene build_scene(const SceneText& text) {
  Scene s{make_mesh(text.mesh), {}, {}};
  s.camera = scene_camera(text, s.mesh);
  s.light = scene_light(text, s.mesh);
  return s;
}

RenderSettings render_settings(const std::string& size, const std::string& background,
                               double repeat, double exposure, double tolerance, bool comparison) {
  RenderSettings s;
  std::tie(s.width, s.height) = parse_size(size, option_name("size"));
  // Before any allocation: a rendering takes about 100 bytes a pixel (surface points, colours,
  // the PNG; measured on a sphere at 2048 x 2048), 130 with the data beside it.
  limits::check_memory(double(s.width) * s.height * (comparison ? 130.0 : 100.0),
                       fmt::format("rendering {}x{} pixels", s.width, s.height),
                       fmt::format("give a smaller {}", option_name("size")));
  s.repeat = repeat;
  s.exposure = exposure;
  s.tolerance = tolerance;
  const auto bg =
      parse_numbers(background, option_name("background"), 3, "40,40,40 (levels 0-255)");
  s.background = {float(bg[0]), float(bg[1]), float(bg[2])};
  return s;
}

const char* synthesis_note() {
  // A synthesis model (the texture models) makes new texture with the data's statistics: its
  // pixels are not the data's, so the pixel-wise figures measure nothing of it.
  return "synthesis: new texture with the data's statistics, the pixel-wise RMSE, PSNR and "
         "SSIM are NOT meaningful (a comparison with the data measures its statistics)";
}

FigureCaption figure_caption(const SceneText& scene, const RenderSettings& settings,
                             const Representation& model) {
  const auto angles = [](const std::string& dir) {
    const auto comma = dir.find(',');
    return fmt::format("θ {}° φ {}°", dir.substr(0, comma), dir.substr(comma + 1));
  };
  FigureCaption c;
  c.model = fmt::format("{}, {}", model.method(), model.size_text());
  const std::string light = scene.point_light.empty()
                                ? "light " + angles(scene.light)
                                : "point light at (" + scene.point_light + ")";
  const std::string camera =
      scene.eye.empty() ? "camera " + angles(scene.camera) : "camera at (" + scene.eye + ")";
  c.scene.push_back(fmt::format(
      "{} · {} · mesh {} · tile repeated {:g}× · exposure {:+g} EV", light, camera,
      std::filesystem::path(scene.mesh).filename().string(), settings.repeat, settings.exposure));
  c.scene.push_back(
      fmt::format("model evaluated to {:g} levels ({}); data interpolated "
                  "between measured directions",
                  settings.tolerance, option_name("tolerance")));
  if (model.synthesises()) c.scene.push_back(synthesis_note());
  return c;
}

}  // namespace btfgmm
