// btfgmm.read_btf, btfgmm.fit and btfgmm.compare: data sets on disk, fitted and measured as
// `btfgmm fit` and `btfgmm compare` do (the library's fit_representation, check_model_frame,
// check_fitted_data, compare_model and comparison_json).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "module.hpp"

namespace btfgmm::python {
namespace {

// A tile given as None (the whole image), "X,Y,W,H" or "auto:WxH" (as `fit --tile`), or a
// tuple (x, y, w, h).
std::string tile_text(const py::object& tile) {
  if (tile.is_none()) return "";
  if (py::isinstance<py::str>(tile)) return tile.cast<std::string>();
  try {
    const auto t = tile.cast<std::tuple<int, int, int, int>>();
    return fmt::format("{},{},{},{}", std::get<0>(t), std::get<1>(t), std::get<2>(t),
                       std::get<3>(t));
  } catch (const py::cast_error&) {
    throw Error(Error::Kind::kArgument,
                "tile: give None (the whole image), (x, y, w, h), \"X,Y,W,H\" or \"auto:WxH\"");
  }
}

// The data set of a BtfData or a path; with a BtfData, its tile, and the seamless tile it is
// (SeamlessTile::describe()) where it was made by cutting.
struct DataArg {
  std::string path;
  std::optional<Tile> tile;
  std::string made;
};

DataArg data_arg(const py::object& data, const char* what) {
  if (py::isinstance<BtfData>(data)) {
    const BtfData& d = data.cast<const BtfData&>();
    return {d.source, d.btf->origin(), d.btf->made_from()};
  }
  return {path_of(data, what), std::nullopt, ""};
}

// The data a DataArg names: the set on disk, or the seamless tile made from it again.
BtfSource open_data(const DataArg& d) {
  return made_tile_source(BtfSource::open(d.path), d.made);
}

BtfData read_btf(const py::object& path, const py::object& tile) {
  BtfData d;
  d.source = path_of(path, "read_btf");
  const std::string text = tile_text(tile);
  py::gil_scoped_release release;
  const BtfSource src = BtfSource::open(d.source);
  const TileChoice c = choose_tile(src, text, "tile");
  d.btf = std::make_shared<Btf>(c.source.load(c.tile));
  d.image_width = src.info().width;
  d.image_height = src.info().height;
  return d;
}

// A seamless tile made by cutting (btfgmm tile -o), as a Btf: its values the made images.
BtfData seamless_tile(const py::object& path, const std::tuple<int, int>& size,
                      const std::optional<std::tuple<int, int>>& overlap) {
  BtfData d;
  d.source = path_of(path, "seamless_tile");
  SeamlessTileConfig c;
  std::tie(c.width, c.height) = size;
  if (overlap) std::tie(c.overlap_x, c.overlap_y) = *overlap;
  py::gil_scoped_release release;
  const BtfSource src = BtfSource::open(d.source);
  d.btf = std::make_shared<Btf>(seamless_tile_source(src, cut_seamless_tile(src, c)).load());
  d.image_width = src.info().width;
  d.image_height = src.info().height;
  return d;
}

// The tile's values, light-major: n_lights x n_views x H x W x 3 float32, sharing its memory.
py::array_t<float> values(const BtfData& d) {
  const Btf& b = *d.btf;
  py::capsule owner(new std::shared_ptr<Btf>(d.btf),
                    [](void* p) { delete static_cast<std::shared_ptr<Btf>*>(p); });
  return py::array_t<float>({py::ssize_t(b.lights().size()), py::ssize_t(b.views().size()),
                             py::ssize_t(b.height()), py::ssize_t(b.width()), py::ssize_t(3)},
                            const_cast<float*>(b.data().data()), owner);
}

// numpy's protocol (np.asarray(btf, dtype)); numpy's further arguments (copy) are numpy's.
py::object as_array(const BtfData& d, const py::object& dtype, const py::kwargs&) {
  py::object a = values(d);
  return dtype.is_none() ? a : a.attr("astype")(dtype);
}

void bind_btf(py::module_& m) {
  py::class_<BtfData>(m, "Btf",
                      "A BTF tile read by read_btf: values (n_lights x n_views x H x W x 3 "
                      "float32; 8- and 16-bit data as 0-255 levels, EXR as linear values), its "
                      "direction sets and where it was read from.")
      .def_property_readonly("values", &values)
      .def_property_readonly("lights",
                             [](const BtfData& d) { return directions_array(d.btf->lights()); })
      .def_property_readonly("views",
                             [](const BtfData& d) { return directions_array(d.btf->views()); })
      .def_property_readonly("origin",
                             [](const BtfData& d) {
                               const Tile& t = d.btf->origin();
                               return py::make_tuple(t.x, t.y, t.width, t.height);
                             })
      .def_property_readonly("format", [](const BtfData& d) { return to_string(d.btf->format()); })
      .def_property_readonly("source", [](const BtfData& d) { return d.source; })
      .def_property_readonly("made_from", [](const BtfData& d) { return d.btf->made_from(); })
      .def_property_readonly(
          "image_size",
          [](const BtfData& d) { return py::make_tuple(d.image_width, d.image_height); })
      .def("__array__", &as_array, py::arg("dtype") = py::none())
      .def("__repr__", [](const BtfData& d) {
        const Btf& b = *d.btf;
        return fmt::format("<btfgmm.Btf '{}': {}x{} tile at ({}, {}), {} lights x {} views, {}>",
                           d.source, b.width(), b.height(), b.origin().x, b.origin().y,
                           b.lights().size(), b.views().size(), to_string(b.format()));
      });
  m.def("read_btf", &read_btf, py::arg("path"), py::arg("tile") = py::none(),
        "Reads a BTF (a folder or Bonn .zip, as `btfgmm info` reads it), its whole images or a "
        "tile: None, (x, y, w, h), \"X,Y,W,H\" or \"auto:WxH\" (a seamless tile: the best "
        "crop where it repeats cleanly, else one made by cutting, as `btfgmm fit --tile auto:` "
        "chooses; made_from names it).");
  m.def("seamless_tile", &seamless_tile, py::arg("path"), py::arg("size"), py::kw_only(),
        py::arg("overlap") = py::none(),
        "Makes a seamless tile of size (w, h) from a BTF as `btfgmm tile --size WxH -o` does: "
        "cut from a region of the tile plus an overlap (default: as many columns and rows as "
        "the images allow, up to half the tile) along the cuts of least error, one cut for all "
        "images. Returns it as a Btf (values: n_lights x n_views x h x w x 3); made_from names "
        "the region and overlap, and fit() and compare() take it as it is.");
}

}  // namespace

void bind_data(py::module_& m) {
  bind_btf(m);
}

// ---- fit and compare ------------------------------------------------------------------------

namespace {

// Ctrl-C and the caller's progress function during a fit that runs without the GIL: checked
// between its steps, with the GIL taken; a Python error (KeyboardInterrupt, or one the
// progress function raises) stops the fit and is raised once it has stopped.
class FitWatch {
 public:
  FitWatch(py::object progress, bool quiet) : progress_(std::move(progress)), quiet_(quiet) {}
  ~FitWatch() {
    Py_XDECREF(type_);
    Py_XDECREF(value_);
    Py_XDECREF(trace_);
  }
  // After EM's iteration `e`: the caller's function, or a line on sys.stderr.
  void iteration(const EmProgress& e) {
    poll(double(e.iteration) / double(e.max_iterations), "EM", [&] {
      return fmt::format("fit: EM iteration {}/{}, L = {:.6f}, {}\n", e.iteration, e.max_iterations,
                         e.log_likelihood, human_seconds(e.seconds));
    });
  }
  // Another stage (the refinement, another method's fit): a line every 5 seconds at most.
  void stage(double fraction, std::string_view stage) {
    poll(fraction, stage, [&] {
      const double now = seconds_since(start_);
      if (fraction < 1.0 && stage == last_stage_ && now < printed_at_ + 5.0) return std::string();
      printed_at_ = now;
      last_stage_ = std::string(stage);
      return fmt::format("fit: {} {:.0f} %, {}\n", stage, 100.0 * fraction, human_seconds(now));
    });
  }
  const std::atomic<bool>* stop() const { return &stop_; }
  // With the GIL held: a model the fit completed although stopped (a mixture stopped in its
  // refinement, or a neural BTF in its epochs, keeps the lowest error met, as the command
  // does) is kept, with a warning, where Ctrl-C stopped it; otherwise the Python error that
  // stopped the fit is raised.
  void raise_if_stopped(bool completed) {
    if (!type_) return;
    if (completed && PyErr_GivenExceptionMatches(type_, PyExc_KeyboardInterrupt)) {
      Py_CLEAR(type_);
      Py_CLEAR(value_);
      Py_CLEAR(trace_);
      if (PyErr_WarnEx(PyExc_RuntimeWarning,
                       "fit: stopped by Ctrl-C; the model of the lowest held-out error met "
                       "is returned (its provenance says where the fit stopped)",
                       1) != 0)
        throw py::error_already_set();
      return;
    }
    PyErr_Restore(type_, value_, trace_);
    type_ = value_ = trace_ = nullptr;
    throw py::error_already_set();
  }

 private:
  template <class Line>
  void poll(double fraction, std::string_view stage, Line&& line) {
    py::gil_scoped_acquire gil;
    if (stop_) return;
    try {
      if (!progress_.is_none()) {
        progress_(fraction, std::string(stage));
      } else if (!quiet_) {
        const std::string text = line();
        if (!text.empty()) py::module_::import("sys").attr("stderr").attr("write")(text);
      }
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    } catch (py::error_already_set& e) {
      e.restore();
      PyErr_Fetch(&type_, &value_, &trace_);
      stop_ = true;
    }
  }

  py::object progress_;
  bool quiet_ = false;
  Clock::time_point start_ = Clock::now();
  double printed_at_ = -1e9;
  std::string last_stage_;
  std::atomic<bool> stop_{false};
  PyObject *type_ = nullptr, *value_ = nullptr, *trace_ = nullptr;
};

// A keyword's value as the declarations take it: a whole number, a real number or a word.
ParameterValue keyword_value(const py::handle& value) {
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::bool_>(value) ||
      !(py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value)))
    return std::string(py::str(py::repr(value)));  // refused as declared, with what it takes
  if (py::isinstance<py::float_>(value)) return value.cast<double>();
  try {
    return value.cast<std::int64_t>();
  } catch (const py::cast_error&) {
    return value.cast<double>();  // beyond 64 bits: out of every range
  }
}

// fit()'s keywords read into the options as the declarations say (each value checked as
// declared: set_parameter), and the fields given, in the declarations' order.
std::vector<std::string_view> read_keywords(const py::kwargs& keywords, FitOptions& o) {
  std::vector<std::string_view> names;
  for (const FitParameter* p : fit_parameters())
    if (!std::holds_alternative<std::monostate>(p->member)) names.push_back(p->field);
  std::vector<std::string_view> given;
  for (const auto& [key, value] : keywords) {
    const std::string name = key.cast<std::string>();
    const FitParameter* p = find_fit_parameter(name);
    if (!p || std::holds_alternative<std::monostate>(p->member))
      throw Error(Error::Kind::kArgument,
                  fmt::format("fit: no option '{}'{}; the options are {}", name,
                              did_you_mean(name, names), fmt::join(names, ", ")));
    if (value.is_none()) continue;  // the default
    set_parameter(o, *p, keyword_value(value));
  }
  for (const std::string_view field : names)
    if (keywords.contains(std::string(field)) && !keywords[py::str(std::string(field))].is_none())
      given.push_back(field);
  return given;
}

Model fit(const py::object& data, const py::object& tile, const py::object& progress, bool quiet,
          const py::kwargs& keywords) {
  const DataArg d = data_arg(data, "fit");
  if (d.tile && !tile.is_none())
    throw Error(Error::Kind::kArgument,
                "fit: a Btf from read_btf is fitted on its own tile; give its path to fit another "
                "tile");
  FitOptions o;
  const std::vector<std::string_view> given = read_keywords(keywords, o);
  check_fit_options(o, given, FitRoute::kNew);  // the one check, before any work
  const std::string text = tile_text(tile);
  FitWatch watch(progress, quiet);
  FitProgress p;
  p.iteration = [&](const EmProgress& e) { watch.iteration(e); };
  p.progress = [&](double fraction, std::string_view stage) { watch.stage(fraction, stage); };
  p.stop = watch.stop();
  std::unique_ptr<Representation> r;
  try {
    py::gil_scoped_release release;
    BtfSource opened = open_data(d);
    Tile t = d.tile ? *d.tile : Tile{};
    if (!d.tile) {
      TileChoice c = choose_tile(opened, text, "tile");
      t = c.tile;
      opened = std::move(c.source);
    }
    r = fit_representation(o, d.path, std::make_shared<const BtfSource>(std::move(opened)), t, p);
  } catch (const Error&) {
    watch.raise_if_stopped(false);  // a method's fit stops by throwing
    throw;
  }
  watch.raise_if_stopped(r != nullptr);
  if (!r) throw Error(Error::Kind::kArgument, "fit: the fit was stopped");
  compute_where_fitted(*r, o);  // its predictions on the device of its fit
  Model m;
  m.rep = std::move(r);
  return m;
}

py::object compare(const py::object& data, const Model& model, bool force) {
  const DataArg d = data_arg(data, "compare");
  const std::string name = model.path.empty() ? "(a model not saved)" : model.path;
  const std::uint64_t bytes = model.bytes();
  nlohmann::json j;
  {
    py::gil_scoped_release release;
    const BtfSource src = BtfSource::open(d.path);
    const BtfInfo& info = src.info();
    check_model_frame(*model.rep, name, info, d.path);
    const ModelFrame& f = model.rep->frame();
    const Btf tile =
        fitted_source(src, model.rep->provenance())
            .load({.x = f.origin.x, .y = f.origin.y, .width = f.width, .height = f.height});
    const DataCheck check =
        check_fitted_data(*model.rep, name, tile, {d.path, info.width, info.height});
    refuse_other_data(check, force, "compare");
    j = comparison_json(d.path, compare_model(tile, model.rep, name, bytes), check.match);
  }
  return to_python(j);
}

// fit()'s documentation: each keyword with its help from the methods' declarations
// (methods/parameters.hpp), the same sentences as `btfgmm fit --help`.
const char* fit_doc() {
  static const std::string doc = [] {
    std::string d =
        "fit(data, *, tile=None, progress=None, quiet=False, **options): fits a model to a BTF "
        "(a path, or a Btf from read_btf: its tile) with the options and defaults of `btfgmm "
        "fit` (None: the method's default); the same data, options and seed give the model "
        "`btfgmm fit` writes. progress(fraction, stage) is called as it goes; without it a line "
        "on sys.stderr tells each EM iteration and every 5 s of the other stages, unless "
        "quiet=True. Ctrl-C stops it: KeyboardInterrupt, but in the mixture's refinement for "
        "the prediction and the neural BTF's epochs, where the model of the lowest held-out "
        "error met is returned (a RuntimeWarning says so), as the command writes it. A value out "
        "of its range or an "
        "option a method does not take raises ArgumentError naming the keyword. The options:";
    for (const FitParameter* p : fit_parameters())
      if (!std::holds_alternative<std::monostate>(p->member))
        d += fmt::format("\n  {}: {}", p->field,
                         spell_options(parameter_help(p->field), option_spelling, "="));
    return d;
  }();
  return doc.c_str();
}

}  // namespace

void bind_fit(py::module_& m) {
  m.def("fit", &fit, py::arg("data"), py::kw_only(), py::arg("tile") = py::none(),
        py::arg("progress") = py::none(), py::arg("quiet") = false, fit_doc());
  m.def("compare", &compare, py::arg("data"), py::arg("model"), py::kw_only(),
        py::arg("force") = false,
        "Measures a model against the BTF it was fitted to (a path, or a Btf from read_btf: "
        "its source; the model's tile is read from it): "
        "the dict `btfgmm compare --json` writes (RMSE, PSNR, SSIM, ratios, ...). Data other "
        "than the model's, by its provenance, is refused unless force=True.");
}

}  // namespace btfgmm::python
