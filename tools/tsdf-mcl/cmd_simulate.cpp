#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_simulate(int, char**) { throw Error("simulate: not implemented yet"); }

}  // namespace tsdf_mcl::cli
