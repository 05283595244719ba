#pragma once
// One function per sub-command of the tsdf-mcl program; each parses its own options and returns the exit code.
namespace tsdf_mcl::cli {

int run_build_map(int argc, char** argv);
int run_info(int argc, char** argv);
int run_simulate(int argc, char** argv);
int run_localize(int argc, char** argv);
int run_evaluate(int argc, char** argv);
int run_bench(int argc, char** argv);
int run_render(int argc, char** argv);
int run_export_cloud(int argc, char** argv);

}  // namespace tsdf_mcl::cli
