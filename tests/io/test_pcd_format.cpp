// PCD headers: WIDTH x HEIGHT must agree with POINTS wherever they are given.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pcd_format.hpp"

namespace tsdf_mcl {
namespace {

io::PcdHeader parse(const std::string& size_lines) {
  std::istringstream in("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + size_lines +
                        "DATA ascii\n");
  return io::parse_pcd_header([&](std::string& line) { return static_cast<bool>(std::getline(in, line)); }, "scan.pcd",
                              1u << 24);
}

TEST(PcdFormat, WidthTimesHeightMustEqualPoints) {
  EXPECT_EQ(parse("WIDTH 100\nHEIGHT 1\nPOINTS 100\n").points, 100u);
  EXPECT_EQ(parse("WIDTH 10\nHEIGHT 10\nPOINTS 100\n").points, 100u);  // organized
  EXPECT_EQ(parse("WIDTH 0\nHEIGHT 1\nPOINTS 0\n").points, 0u);
  EXPECT_EQ(parse("POINTS 100\n").points, 100u);             // WIDTH and HEIGHT are optional
  EXPECT_EQ(parse("WIDTH 100\nPOINTS 100\n").points, 100u);  // HEIGHT defaults to 1
  for (const char* wh : {"WIDTH 50\nHEIGHT 1\n", "WIDTH 100\nHEIGHT 2\n", "WIDTH 0\nHEIGHT 1\n",
                         "WIDTH 100\nHEIGHT 0\n", "WIDTH 200\nHEIGHT 1\n", "HEIGHT 3\n", "WIDTH 33\nHEIGHT 3\n"}) {
    try {
      parse(std::string(wh) + "POINTS 100\n");
      ADD_FAILURE() << wh << "was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("scan.pcd: PCD WIDTH x HEIGHT"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("differs from POINTS 100"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace tsdf_mcl
