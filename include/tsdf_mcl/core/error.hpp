#pragma once
// One exception type for every user-facing failure: the CLI's main catches it and prints what() as one line.
#include <stdexcept>
#include <string>

namespace tsdf_mcl {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace tsdf_mcl
