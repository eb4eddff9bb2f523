// The Python module btfgmm: its exceptions and its parts (module_model.cpp: load and Model;
// module_data.cpp: read_btf, fit and compare).
#include <pybind11/pybind11.h>

#include <algorithm>
#include <exception>
#include <string>
#include <string_view>

#include "btfgmm/core/text.hpp"
#include "module.hpp"

namespace btfgmm::python {
namespace {

// btfgmm.Error and its kinds: a bad request or a malformed file is a ValueError, a file that
// cannot be read or written an OSError; each carries the library's message.
struct ErrorClasses {
  PyObject* base = nullptr;
  PyObject* argument = nullptr;
  PyObject* format = nullptr;
  PyObject* io = nullptr;
};

PyObject* new_error(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  const std::string full = std::string("btfgmm.") + name;
  PyObject* cls = PyErr_NewExceptionWithDoc(full.c_str(), doc, bases, nullptr);
  if (!cls) throw py::error_already_set();
  m.add_object(name, py::handle(cls));
  return cls;
}

PyObject* bases(PyObject* a, PyObject* b) {
  return py::make_tuple(py::handle(a), py::handle(b)).release().ptr();
}

std::string message_text(std::string_view message) {
  return spell_options(message, option_spelling, "=");
}

ErrorClasses register_errors(py::module_& m) {
  ErrorClasses e;
  e.base = new_error(m, "Error", PyExc_Exception, "Every error of the btfgmm library.");
  e.argument = new_error(m, "ArgumentError", bases(e.base, PyExc_ValueError),
                         "A request that makes no sense: a bad option, shape or direction.");
  e.format = new_error(m, "FormatError", bases(e.base, PyExc_ValueError),
                       "A file whose contents or name are not what they should be.");
  e.io = new_error(m, "FileError", bases(e.base, PyExc_OSError),
                   "A file or folder that cannot be read or written.");
  return e;
}

// numpy is imported up front, so that a Python without it is told what to install rather than
// failing at the first array with pybind11's "numpy.core.multiarray failed to import".
void require_numpy() {
  try {
    py::module_::import("numpy");
  } catch (const py::error_already_set&) {
    const std::string python = py::str(py::module_::import("sys").attr("executable"));
    throw py::import_error("btfgmm needs numpy, which " + python +
                           " cannot import: on Debian, apt install python3-numpy, and use the "
                           "interpreter the module was built for (" BTFGMM_PYTHON_BUILT_FOR
                           "; docs/PYTHON.md)");
  }
}

}  // namespace

std::string path_of(const py::handle& h, const char* what) {
  const py::module_ os = py::module_::import("os");
  if (py::isinstance<py::str>(h) || py::hasattr(h, "__fspath__"))
    return py::str(os.attr("fspath")(h)).cast<std::string>();
  throw Error(Error::Kind::kArgument,
              std::string(what) + ": give a path (a str or os.PathLike), not " +
                  py::str(py::type::handle_of(h).attr("__name__")).cast<std::string>());
}

py::object to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

py::array_t<double> directions_array(const DirectionSet& s) {
  py::array_t<double> a({py::ssize_t(s.size()), py::ssize_t(2)});
  auto v = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < s.size(); ++i) {
    v(py::ssize_t(i), 0) = s[i].theta_deg;
    v(py::ssize_t(i), 1) = s[i].phi_deg;
  }
  return a;
}

}  // namespace btfgmm::python

PYBIND11_MODULE(btfgmm, m) {
  using namespace btfgmm::python;
  m.doc() =
      "btfgmm: measured material appearance (BTFs) as a Gaussian mixture, and the methods it is "
      "compared with. load() a model, eval() and decode() it, read_btf() data, fit() and "
      "compare() as the btfgmm command does (docs/PYTHON.md).";
  require_numpy();
  static const ErrorClasses errors = register_errors(m);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const btfgmm::Error& e) {
      using Kind = btfgmm::Error::Kind;
      PyObject* cls = e.kind() == Kind::kIo       ? errors.io
                      : e.kind() == Kind::kFormat ? errors.format
                                                  : errors.argument;
      PyErr_SetString(cls, btfgmm::python::message_text(e.what()).c_str());
    }
  });
  bind_model(m);
  bind_data(m);
  bind_fit(m);
}
