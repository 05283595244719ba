// tsdf-mcl-bench: the sensor-update benchmark, the program `tsdf-mcl bench` runs (docs/architecture.md's contract:
// one JSON line per measurement). It keeps the benchmark and the reference design it compares with out of tsdf-mcl.
#include "bench_command.hpp"
#include "run_command.hpp"

int main(int argc, char** argv) {
  return tsdf_mcl::cli::run_command("bench", tsdf_mcl::bench::run_bench_command, argc, argv);
}
