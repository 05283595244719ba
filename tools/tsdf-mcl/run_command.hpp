#pragma once
// One command's run with the program's answer to failure: an Error is one line `tsdf-mcl CMD: error: ...` and exit
// code 1, running out of memory too; any other exception an internal error (exit code 3). tsdf-mcl and the
// benchmark program (bench/) answer alike.
namespace tsdf_mcl::cli {

int run_command(const char* name, int (*run)(int, char**), int argc, char** argv);

}  // namespace tsdf_mcl::cli
