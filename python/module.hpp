// The Python module btfgmm (docs/PYTHON.md): what its parts share. The module only converts
// between numpy arrays and the library's types and calls the library; every rule (defaults,
// checks, messages) is the library's, so that the module and the command agree.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "btfgmm/btfgmm.hpp"

namespace btfgmm::python {

namespace py = pybind11;

// A model of any method, as load, fit and Model.save know it.
struct Model {
  std::shared_ptr<const Representation> rep;
  std::string path;              // the file it was read from or last saved to; empty: none
  std::uint64_t file_bytes = 0;  // that file's size
  // The bytes of its file: the file's size, or, never written, the size it would have.
  std::uint64_t bytes() const;
};

// A BTF tile read by read_btf: the library's container and where it came from.
struct BtfData {
  std::shared_ptr<Btf> btf;
  std::string source;  // the folder or .zip as given
  int image_width = 0, image_height = 0;
};

// A str or os.PathLike as a path; Error(kArgument) naming `what` otherwise.
std::string path_of(const py::handle& h, const char* what);
// nlohmann JSON as Python objects (json.loads of its text).
py::object to_python(const nlohmann::json& j);
// A direction set as an n x 2 float64 array of (theta, phi) in degrees.
py::array_t<double> directions_array(const DirectionSet& s);

// The options a library message names (core/text.hpp, option_name), as this module's messages
// spell them: as fit()'s keywords, which are the library's field names ("refine_steps"), so that
// a Python caller is told about the argument it passed, not about a command-line flag; with a
// value, as it was passed ("epsilon=5": spell_options's separator "=").
inline std::string option_spelling(std::string_view field) {
  return std::string(field);
}

void bind_model(py::module_& m);
void bind_data(py::module_& m);
void bind_fit(py::module_& m);

}  // namespace btfgmm::python
