// Errors of the btfgmm library.
//
// The library never prints and never exits. A programmer's mistake (a precondition the
// caller controls) is an assertion; bad data or a bad request (a missing image, a name that
// does not parse, NaN in an EXR, a corrupt model file, a nonsense option) throws
// btfgmm::Error, whose message names the file or field at fault and says what would fix it.
#pragma once

#include <stdexcept>
#include <string>

namespace btfgmm {

class Error : public std::runtime_error {
 public:
  enum class Kind {
    kIo,        // a file or folder could not be read or written
    kFormat,    // a file's contents or name are not what they should be
    kArgument,  // a request that makes no sense (a tile outside the image, M = 0, ...)
  };

  Error(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}

  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

}  // namespace btfgmm
