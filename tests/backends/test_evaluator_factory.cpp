#include <gtest/gtest.h>

#include <string>

#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "sensor_test_support.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

TEST(EvaluatorFactory, AutoSaysWhatItPickedAndCpuIsAlwaysThere) {
  const TsdfMap map = test::make_room_map();
  std::string note;
  EvaluatorOptions o;
  o.backend = Backend::kCpu;
  EXPECT_EQ(make_evaluator(map, o, &note)->backend(), "cpu");
  EXPECT_NE(note.find("cpu"), std::string::npos);
  o.backend = Backend::kAuto;
  o.on_validation_message = [](const std::string& m) { ADD_FAILURE() << m; };
  const auto e = make_evaluator(map, o, &note);
  EXPECT_NE(note.find(e->backend()), std::string::npos) << note;
  EXPECT_THROW(parse_backend("cuda"), Error);
}

}  // namespace
}  // namespace tsdf_mcl
