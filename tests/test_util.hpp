// Helpers shared by the test files.
#pragma once

#include <gtest/gtest.h>

#include <exception>
#include <string>

#include "btfgmm/core/error.hpp"

namespace btfgmm::test {

// The message of the btfgmm::Error `f` throws; a test failure if it throws nothing or
// something else.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const btfgmm::Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a btfgmm::Error: " << e.what();
    return "";
  }
  ADD_FAILURE() << "no error";
  return "";
}

}  // namespace btfgmm::test
