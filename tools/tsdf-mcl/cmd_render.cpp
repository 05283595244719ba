#include "commands.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl::cli {

int run_render(int, char**) { throw Error("render: not implemented yet"); }

}  // namespace tsdf_mcl::cli
