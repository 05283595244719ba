#include <gtest/gtest.h>

#include <string>

#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl {
namespace {

TEST(OneLine, EscapesControlCharactersAndInvalidUtf8KeepsText) {
  EXPECT_EQ(one_line("plain text, 100 %"), "plain text, 100 %");
  EXPECT_EQ(one_line("a\nb\tc\rd"), "a\\nb\\tc\\rd");
  EXPECT_EQ(one_line(std::string("x\0y", 3)), "x\\x00y");
  EXPECT_EQ(one_line("\x7f"), "\\x7F");
  EXPECT_EQ(one_line("B\xc3\xbcro \xe6\x9d\xb1"), "B\xc3\xbcro \xe6\x9d\xb1");  // UTF-8 kept
  EXPECT_EQ(one_line("\xc3"), "\\xC3");                                         // truncated sequence
  EXPECT_EQ(one_line("\xc0\xaf"), "\\xC0\\xAF");                                // overlong
  EXPECT_EQ(one_line("\xed\xa0\x80"), "\\xED\\xA0\\x80");                       // UTF-16 surrogate
}

}  // namespace
}  // namespace tsdf_mcl
