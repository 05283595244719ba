#include "run_command.hpp"

#include <cstdio>
#include <exception>
#include <new>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::cli {

int run_command(const char* name, int (*run)(int, char**), int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const Error& e) {
    std::fprintf(stderr, "tsdf-mcl %s: error: %s\n", name, one_line(e.what()).c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    // Inputs are bounded by the documented limits (README "Limits"); within them the machine may still run out.
    std::fprintf(stderr, "tsdf-mcl %s: error: out of memory (see the limits in README.md)\n", name);
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tsdf-mcl %s: internal error: %s\n", name, one_line(e.what()).c_str());
    return 3;
  }
}

}  // namespace tsdf_mcl::cli
