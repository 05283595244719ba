#pragma once
// Where the built program and this checkout's test data are. Only checkout_paths.cpp is compiled with these folders
// (tests/CMakeLists.txt): the other test files' compile commands name no folder of the checkout, so that a clean
// checkout elsewhere (CI's) finds them in ccache.

namespace tsdf_mcl::test {

const char* cli_program();      // the tsdf-mcl program of this build
const char* shared_data_dir();  // ../shared/data beside the project (may be absent)
const char* test_data_dir();    // tests/data
const char* fuzz_data_dir();    // fuzz/ (corpus/ and regressions/)

}  // namespace tsdf_mcl::test
