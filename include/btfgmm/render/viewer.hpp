// The real-time viewer (docs/RENDERING.md, "The viewer"): a self-contained folder whose
// index.html renders models in WebGL2 with their exported shaders (render/shader.hpp) on the
// built-in meshes, opened from the file system (no server, no network): the page's script and
// the data are .js files loaded by <script src>, the data as base64.
#pragma once

#include <string>
#include <vector>

#include "btfgmm/methods/representation.hpp"
#include "btfgmm/render/shader.hpp"

namespace btfgmm {

struct ViewerFile {
  std::string name;  // relative to the folder
  std::string text;
};

// One model of the page: its name as shown, and the representation.
struct ViewerModel {
  std::string name;
  const Representation* model = nullptr;
};

// The page's files: index.html, viewer.js, meshes.js (the built-in meshes: sphere, cloth,
// plane, cylinder) and models.js (every model's shader and parameters). Throws as
// export_shader() for a method without a shader, Error(kArgument) for no model. The page shows
// `cpu_command`, the front end's command that renders the same view on the CPU, with {mesh},
// {light}, {camera}, {repeat}, {fov}, {exposure} and {size} replaced by the view's settings
// (empty: none shown).
std::vector<ViewerFile> viewer_files(const std::vector<ViewerModel>& models,
                                     const std::string& cpu_command = "");

// The script that adds one model to the page's list (models.js holds one a model): its name,
// method, size, tile, sample format and shader.
std::string viewer_model_script(const std::string& name, const Representation& model,
                                const ShaderExport& shader);
// The same for a shader read back from export-shader's files (the GLSL text and the
// parameter file), with the facts the page shows given: for a page of exported shaders.
std::string viewer_model_script(const std::string& name, const std::string& size_text,
                                const ModelFrame& frame, const ShaderExport& shader);

// Standard base64 (RFC 4648, with padding).
std::string base64(const void* bytes, std::size_t size);

}  // namespace btfgmm
