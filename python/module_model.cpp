// btfgmm.load and btfgmm.Model: any method's model, evaluated at queries (Eq. 8-11 for the
// mixture), decoded into images, described and saved.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "module.hpp"

namespace btfgmm::python {
namespace {

namespace fs = std::filesystem;

// One direction of a query row or an argument, checked as the command checks --light/--view.
Direction direction(double theta, double phi, const std::string& what) {
  return hemisphere_direction(theta, phi, what, fmt::format("{:g},{:g}", theta, phi));
}

// The queries of Model.eval: an N x 6 array (or one row of 6) of x, y, light theta, light phi,
// view theta, view phi; the directions in degrees.
std::vector<Query> queries_of(
    const py::array_t<double, py::array::c_style | py::array::forcecast>& a) {
  const bool one = a.ndim() == 1;
  if (!((one && a.shape(0) == 6) || (a.ndim() == 2 && a.shape(1) == 6))) {
    std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
    throw Error(Error::Kind::kArgument,
                fmt::format("eval: queries must be an N x 6 array (x, y, light theta, light phi, "
                            "view theta, view phi; angles in degrees), not of shape ({})",
                            fmt::join(shape, ", ")));
  }
  const py::ssize_t n = one ? 1 : a.shape(0);
  const double* v = a.data();
  std::vector<Query> q(static_cast<std::size_t>(n));
  for (py::ssize_t i = 0; i < n; ++i) {
    const double* r = v + 6 * i;
    if (!std::isfinite(r[0]) || !std::isfinite(r[1]))
      throw Error(
          Error::Kind::kArgument,
          fmt::format("eval: query {}: x and y must be finite, not {:g}, {:g}", i, r[0], r[1]));
    q[std::size_t(i)] = {.x = r[0],
                         .y = r[1],
                         .light = direction(r[2], r[3], fmt::format("eval: query {}: light", i)),
                         .view = direction(r[4], r[5], fmt::format("eval: query {}: view", i))};
  }
  return q;
}

py::array_t<float> eval(const Model& m,
                        const py::array_t<double, py::array::c_style | py::array::forcecast>& a) {
  const std::vector<Query> q = queries_of(a);
  std::vector<float> rgb(q.size() * 3);
  {
    py::gil_scoped_release release;
    m.rep->predict(q, rgb);
  }
  std::vector<py::ssize_t> shape = {py::ssize_t(q.size()), 3};
  if (a.ndim() == 1) shape = {3};
  py::array_t<float> out(shape);
  std::copy(rgb.begin(), rgb.end(), out.mutable_data());
  return out;
}

// A (theta, phi) pair in degrees.
Direction direction_arg(const std::pair<double, double>& d, const char* what) {
  return direction(d.first, d.second, what);
}

// size: None (the tile), N (N x N) or (W, H).
std::pair<int, int> size_arg(const py::object& size, const ModelFrame& f) {
  if (size.is_none()) return {f.width, f.height};
  std::pair<long long, long long> wh;
  if (py::isinstance<py::int_>(size)) {
    wh.first = wh.second = size.cast<long long>();
  } else {
    try {
      wh = size.cast<std::pair<long long, long long>>();
    } catch (const py::cast_error&) {
      throw Error(Error::Kind::kArgument, "decode: size must be None (the tile), N or (W, H)");
    }
  }
  if (wh.first < 1 || wh.second < 1 || wh.first > 65536 || wh.second > 65536)
    throw Error(Error::Kind::kArgument,
                fmt::format("decode: size {} x {} is not a size; give N or (W, H) pixels "
                            "(1..65536)",
                            wh.first, wh.second));
  return {int(wh.first), int(wh.second)};
}

// One image of H x W x 3 float32, in the data's scale, the tile repeated to `size`.
py::array_t<float> decode(const Model& m, std::pair<double, double> light,
                          std::pair<double, double> view, const py::object& size,
                          double tolerance) {
  const DirectionSet lights({direction_arg(light, "decode: light")});
  const DirectionSet views({direction_arg(view, "decode: view")});
  const auto [w, h] = size_arg(size, m.rep->frame());
  if (!(tolerance >= 0.0))
    throw Error(Error::Kind::kArgument, "decode: tolerance must be >= 0 (0: every component)");
  auto btf = std::make_shared<Btf>();
  {
    py::gil_scoped_release release;
    *btf = m.rep->decode(lights, views, w, h, tolerance);
  }
  float* data = btf->image(0, 0);
  py::capsule owner(new std::shared_ptr<Btf>(btf),
                    [](void* p) { delete static_cast<std::shared_ptr<Btf>*>(p); });
  return py::array_t<float>({py::ssize_t(h), py::ssize_t(w), py::ssize_t(3)}, data, owner);
}

py::dict frame_dict(const ModelFrame& f) {
  py::dict d;
  d["lights"] = directions_array(f.lights);
  d["views"] = directions_array(f.views);
  d["width"] = f.width;
  d["height"] = f.height;
  d["origin"] = py::make_tuple(f.origin.x, f.origin.y, f.origin.width, f.origin.height);
  d["format"] = to_string(f.format);
  return d;
}

py::dict provenance_dict(const Provenance& p) {
  py::dict d;
  d["recorded"] = p.recorded;
  d["source"] = p.data.source.name;
  d["image_size"] = py::make_tuple(p.data.source.image_width, p.data.source.image_height);
  d["content_hash"] = hash_text(p.data.content_hash);
  d["fit_seconds"] = p.fit.seconds;
  d["runs"] = p.fit.runs;
  py::dict settings;
  for (const auto& [k, v] : p.fit.settings) settings[py::str(k)] = v;
  d["settings"] = settings;
  py::list iterations;
  for (const IterationRecord& it : p.fit.iterations)
    iterations.append(py::make_tuple(it.log_likelihood, it.seconds, it.components));
  d["iterations"] = iterations;
  return d;
}

// The model of a file, its predictions (eval, decode, compare) on the device `device` names.
Model load(const py::object& path, const std::string& device) {
  const std::optional<DeviceChoice> choice = parse_device_choice(device);
  if (!choice)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("load: device '{}' is not a device; give 'auto', 'cpu' or 'gpu'", device));
  Model m;
  m.path = path_of(path, "load");
  std::unique_ptr<Representation> rep = load_representation(m.path);
  compute_predictions_on(*rep, *choice, m.path);
  m.rep = std::move(rep);
  m.file_bytes = fs::file_size(m.path);
  return m;
}

// Writes the model atomically; an existing file only with overwrite. Returns its bytes.
std::uint64_t save(Model& m, const py::object& path, bool overwrite) {
  const std::string p = path_of(path, "save");
  std::error_code ec;
  if (fs::exists(p, ec) && !overwrite)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("'{}' exists; give a new name or pass overwrite=True to replace it", p));
  const std::uint64_t bytes = save_representation(*m.rep, p);
  m.path = p;
  m.file_bytes = bytes;
  return bytes;
}

std::string repr(const Model& m) {
  return fmt::format("<btfgmm.Model {} {}, {}x{} tile, {} lights x {} views{}>", m.rep->method(),
                     m.rep->size_text(), m.rep->frame().width, m.rep->frame().height,
                     m.rep->frame().lights.size(), m.rep->frame().views.size(),
                     m.path.empty() ? std::string() : ", from '" + m.path + "'");
}

}  // namespace

std::uint64_t Model::bytes() const {
  return !path.empty() ? file_bytes : representation_file_bytes(*rep).size();
}

void bind_model(py::module_& m) {
  py::class_<Model>(m, "Model", "A fitted model of a BTF tile, any method (docs/METHODS.md).")
      .def("eval", &eval, py::arg("queries"),
           "The RGB of each query: an N x 6 array of x, y (tile pixels, integers at pixel "
           "centres; the tile repeats), light theta, phi, view theta, phi (degrees), as "
           "`btfgmm eval` takes them. Returns N x 3 float32 in the data's scale.")
      .def("decode", &decode, py::arg("light"), py::arg("view"), py::arg("size") = py::none(),
           py::arg("tolerance") = kDecodeTolerance,
           "The image for one light and view (theta, phi in degrees): H x W x 3 float32, the "
           "tile repeated to size (None: the tile; N; or (W, H)), as `btfgmm decode`.")
      .def("save", &save, py::arg("path"), py::arg("overwrite") = false,
           "Writes the model file atomically (an existing file only with overwrite=True); "
           "returns its size in bytes.")
      .def_property_readonly("method", [](const Model& x) { return std::string(x.rep->method()); })
      .def_property_readonly("size", [](const Model& x) { return x.rep->size_text(); })
      .def_property_readonly("parameters", [](const Model& x) { return x.rep->parameter_count(); })
      .def_property_readonly("paper_ratio", [](const Model& x) { return x.rep->paper_ratio(); })
      .def_property_readonly("file_ratio",
                             [](const Model& x) { return x.rep->file_ratio(x.bytes()); })
      .def_property_readonly("file_bytes", &Model::bytes)
      .def_property_readonly("path",
                             [](const Model& x) -> py::object {
                               return x.path.empty() ? py::object(py::none())
                                                     : py::object(py::str(x.path));
                             })
      .def_property_readonly("frame", [](const Model& x) { return frame_dict(x.rep->frame()); })
      .def_property_readonly("details",
                             [](const Model& x) {
                               nlohmann::json j;
                               put_model_json(j, *x.rep);
                               return to_python(j);
                             })
      .def_property_readonly("provenance",
                             [](const Model& x) { return provenance_dict(x.rep->provenance()); })
      .def("__repr__", &repr);
  m.def("load", &load, py::arg("path"), py::kw_only(), py::arg("device") = "auto",
        "Reads a model file of any method (.btfgmm). device: where its predictions (eval, "
        "decode, compare) are computed: 'auto' (a GPU where one exists, else the CPU), 'cpu', "
        "or 'gpu' (a GPU, else a software Vulkan; the Gaussian mixture's and the neural BTF's "
        "alone).");
}

}  // namespace btfgmm::python
