// A scene as text, as `btfgmm render` and a caller describe it: the mesh, the camera and the
// light, parsed and built here (the point light's falloff, the camera's default target), the
// settings of the picture, the memory a rendering takes, and the scene's lines under the
// comparison figure.
#pragma once

#include <string>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/render/camera.hpp"
#include "btfgmm/render/figure.hpp"
#include "btfgmm/render/mesh.hpp"

namespace btfgmm {

class Representation;

// Each field as its option takes it; messages name the fields (core/text.hpp, option_name).
struct SceneText {
  std::string mesh = "sphere";  // sphere, cylinder, cloth, plane or a Wavefront .obj file
  std::string light = "45,30";  // THETA,PHI in degrees (world, z up; theta 0-180)
  std::string point_light;      // X,Y,Z: a point light there instead
  double intensity = 1.0;       // 1: as measured; a point light: at the object's centre
  std::string camera = "60,0";  // orbit camera THETA,PHI in degrees around the object
  std::string eye;              // X,Y,Z: a look-at camera there instead
  std::string target;           // the point looked at (empty: the object's centre)
  std::string up = "0,0,1";     // the look-at camera's up direction
  double fov = 30.0;            // vertical field of view, degrees
};

struct Scene {
  Mesh mesh;
  Camera camera;
  Light light;
};

// The scene `text` describes. Throws Error as make_mesh, and Error(kArgument) naming the field
// for a direction or a point that does not parse.
Scene build_scene(const SceneText& text);

// A world direction "THETA,PHI": theta from +z in [0, 180] (a light or a camera may be below
// the object), phi from +x toward +y, wrapped into [0, 360). Error(kArgument) naming `field`.
Direction parse_world_direction(const std::string& text, const std::string& field);

// The picture's settings: `size` "WxH" (or "N"), `background` "R,G,B" levels, and the tile
// repeat, exposure and tolerance as given. Error(kArgument) naming the field, and before any
// allocation where a rendering of that size (`comparison`: with the data beside the model)
// needs more memory than the machine has.
RenderSettings render_settings(const std::string& size, const std::string& background,
                               double repeat, double exposure, double tolerance, bool comparison);

// The comparison figure's lines besides its metrics: the model and the scene (and, for a
// synthesis model, that the pixel-wise figures mean nothing: synthesis_note()).
FigureCaption figure_caption(const SceneText& scene, const RenderSettings& settings,
                             const Representation& model);
const char* synthesis_note();

}  // namespace btfgmm
