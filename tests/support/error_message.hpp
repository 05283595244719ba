#pragma once
// The message of the tsdf_mcl::Error a call throws, for tests that check what an error says.
#include <functional>
#include <string>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::test {

// `f`'s Error message, or "" when it throws none.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace tsdf_mcl::test
