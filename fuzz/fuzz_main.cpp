// One libFuzzer harness: TSDF_MCL_FUZZ_TARGET names the target of fuzz_targets.hpp (fuzz/CMakeLists.txt).
#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  tsdf_mcl::fuzz::TSDF_MCL_FUZZ_TARGET(data, size);
  return 0;
}
