#include "checkout_paths.hpp"

namespace tsdf_mcl::test {

const char* cli_program() { return TSDF_MCL_CLI; }
const char* shared_data_dir() { return TSDF_MCL_SHARED_DATA; }
const char* test_data_dir() { return TSDF_MCL_TEST_DATA; }
const char* fuzz_data_dir() { return TSDF_MCL_FUZZ_DATA; }

}  // namespace tsdf_mcl::test
