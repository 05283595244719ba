#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_build_map(int, char**) { throw Error("not implemented yet"); }

}  // namespace tsdf_mcl::cli
