#pragma once
// Runs the tsdf-mcl program (path from the TSDF_MCL_CLI compile definition) for command-line tests.
#include <sys/wait.h>

#include <cstdlib>
#include <string>

#include "map_test_helpers.hpp"

namespace tsdf_mcl::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

// `args` is pasted into a shell command line; stdout and stderr are captured through files in `dir`.
inline CliResult run_cli(const TempDir& dir, const std::string& args) {
  const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command =
      std::string("'") + TSDF_MCL_CLI + "' " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_bytes(out);
  r.err = read_bytes(err);
  return r;
}

}  // namespace tsdf_mcl::test
