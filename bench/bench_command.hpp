#pragma once
// The bench command (`tsdf-mcl bench`, which runs this program): its options, checked, then the sensor-update
// benchmark on a map and one scan of a dataset.
namespace tsdf_mcl::bench {

// argv[1..] are the command's options; returns the exit code. Throws Error for bad input.
int run_bench_command(int argc, char** argv);

}  // namespace tsdf_mcl::bench
