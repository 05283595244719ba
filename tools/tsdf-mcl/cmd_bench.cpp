#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_bench(int, char**) { throw Error("not implemented yet"); }

}  // namespace tsdf_mcl::cli
