#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_localize(int, char**) { throw Error("localize: not implemented yet"); }

}  // namespace tsdf_mcl::cli
