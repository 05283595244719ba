// `tsdf-mcl bench` runs the benchmark program installed beside this one (bench/: tsdf-mcl-bench) with the same
// options, in this process's place: the program does not carry the benchmark and the reference design it times.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::cli {

int run_bench(int argc, char** argv) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("cannot find this program's own path in /proc/self/exe: " + ec.message());
  std::string bench = (self.parent_path() / "tsdf-mcl-bench").string();
  std::vector<char*> args{bench.data()};
  for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  std::fflush(nullptr);
  execv(bench.c_str(), args.data());
  throw Error("cannot run the benchmark program " + bench + ": " + std::strerror(errno));
}

}  // namespace tsdf_mcl::cli
