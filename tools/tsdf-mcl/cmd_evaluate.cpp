#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_evaluate(int, char**) { throw Error("evaluate: not implemented yet"); }

}  // namespace tsdf_mcl::cli
