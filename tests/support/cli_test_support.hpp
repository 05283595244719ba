#pragma once
// Runs the tsdf-mcl program (checkout_paths.hpp) for command-line tests.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "map_test_helpers.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

// `args` is pasted into a shell command line; stdout and stderr are captured through files in `dir`.
inline CliResult run_cli(const TempDir& dir, const std::string& args) {
  const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command =
      std::string("'") + cli_program() + "' " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_bytes(out);
  r.err = read_bytes(err);
  return r;
}

// A bad invocation: non-zero exit, exactly one line on stderr, naming what is wrong.
inline void expect_one_line_error(const TempDir& dir, const std::string& args, const std::string& words) {
  const CliResult r = run_cli(dir, args);
  EXPECT_NE(r.exit_code, 0) << args;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << "\n" << r.err;
  EXPECT_NE(r.err.find(words), std::string::npos) << args << ": '" << r.err << "' lacks '" << words << "'";
}

}  // namespace tsdf_mcl::test
