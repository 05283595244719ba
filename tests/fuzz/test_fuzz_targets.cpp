// Every fuzz seed and every input a fuzzer once found crashing (fuzz/corpus/NAME, fuzz/regressions/NAME) runs
// through its fuzz target in every build: regressions stay fixed without a fuzzer, and the sanitizer run checks them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl::fuzz {
// Test names and failure messages show the target's name.
void PrintTo(const Target& target, std::ostream* out) { *out << target.name; }
}  // namespace tsdf_mcl::fuzz

namespace {

class FuzzInputs : public ::testing::TestWithParam<tsdf_mcl::fuzz::Target> {};

TEST_P(FuzzInputs, LoadOrFailWithAnError) {
  const tsdf_mcl::fuzz::Target& target = GetParam();
  std::size_t inputs = 0;
  for (const char* kind : {"corpus", "regressions"}) {
    const std::filesystem::path dir = std::filesystem::path(tsdf_mcl::test::fuzz_data_dir()) / kind / target.name;
    if (!std::filesystem::is_directory(dir)) continue;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      std::ifstream in(entry.path(), std::ios::binary);
      const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
      SCOPED_TRACE(entry.path().string());
      target.run(bytes.data(), bytes.size());
      ++inputs;
    }
  }
  EXPECT_GT(inputs, 0u) << "no seeds for " << target.name;
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzInputs, ::testing::ValuesIn(tsdf_mcl::fuzz::kTargets),
                         [](const auto& target) { return std::string(target.param.name); });

}  // namespace
