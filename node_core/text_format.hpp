#pragma once
// printf into a std::string, for the core's messages (a reason, a rejection, a log line).
#include <cstdarg>
#include <cstdio>
#include <string>

namespace tsdf_mcl::node {

inline std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
inline std::string format(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof(buf), fmt, args);
  va_end(args);
  return buf;
}

}  // namespace tsdf_mcl::node
