#pragma once
// The text of the tsdf_mcl::Error a call throws ("" where it throws none): the tests compare error sentences.
#include <functional>
#include <string>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::test {

inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace tsdf_mcl::test
