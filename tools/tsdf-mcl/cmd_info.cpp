#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_info(int, char**) { throw Error("not implemented yet"); }

}  // namespace tsdf_mcl::cli
