// call_isolated (isolated_call.hpp): a child's answer, its error and its crash each come back to the caller.
#include <gtest/gtest.h>
#include <signal.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/isolated_call.hpp"
#include "tsdf_mcl/mapping/h5_import.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl {
namespace {

std::string crash_words(const std::string& how) { return "the work crashed (" + how + ")"; }

std::string error_of(const std::function<std::string()>& work) {
  try {
    call_isolated(work, crash_words);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(IsolatedCall, AnswersErrorsAndCrashesComeBack) {
  const std::string big(300000, 'x');  // more than a pipe holds at once
  EXPECT_EQ(call_isolated([&] { return std::string("a\0b", 3) + big; }, crash_words), std::string("a\0b", 3) + big);
  EXPECT_EQ(call_isolated([] { return std::string(); }, crash_words), "");
  EXPECT_EQ(error_of([]() -> std::string { throw std::runtime_error("bad header in x.h5"); }), "bad header in x.h5");
  EXPECT_EQ(error_of([]() -> std::string { std::_Exit(3); }), "the work crashed (exit status 3)");
  EXPECT_EQ(error_of([]() -> std::string {
              ::raise(SIGKILL);
              return "";
            }),
            "the work crashed (signal 9)");
}

// A library caller of the HDF5 import gets the isolation too: a file libhdf5 crashes on is one Error, a good one the
// same map as without isolation, and the scratch file is gone either way.
TEST(IsolatedCall, TheHdf5ImportIsIsolatedForLibraryCallers) {
  test::TempDir dir;
  try {
    import_reference_h5_isolated(std::string(tsdf_mcl::test::test_data_dir()) + "/libhdf5_crash_local_heap.h5", 0.6f,
                                 std::uint64_t{256} << 20, dir.path());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("libhdf5_crash_local_heap.h5"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace tsdf_mcl
