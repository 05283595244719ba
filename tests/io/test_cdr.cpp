// CDR (include/tsdf_mcl/io/cdr.hpp): the encapsulation header, alignment from the end of the header, both byte
// orders, strings with their NUL, and lengths checked against the bytes left.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/cdr.hpp"

namespace tsdf_mcl {
namespace {

using test::error_of;

TEST(Cdr, LayoutAsXcdr1InBothByteOrders) {
  // uint8, then a float64 aligned to 8 counted from the end of the header, a string with its NUL, an int32.
  for (const bool little : {true, false}) {
    cdr::Writer w(little);
    w.value<std::uint8_t>(7);
    w.value<double>(1.5);
    w.string("ab");
    w.value<std::int32_t>(-2);
    const std::vector<std::uint8_t> bytes = w.take();
    const std::vector<std::uint8_t> double_bytes = little ? std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0xF8, 0x3F}
                                                          : std::vector<std::uint8_t>{0x3F, 0xF8, 0, 0, 0, 0, 0, 0};
    std::vector<std::uint8_t> expected = {0, static_cast<std::uint8_t>(little ? 1 : 0), 0, 0, 7, 0, 0, 0, 0, 0, 0, 0};
    expected.insert(expected.end(), double_bytes.begin(), double_bytes.end());
    const std::vector<std::uint8_t> length =
        little ? std::vector<std::uint8_t>{3, 0, 0, 0} : std::vector<std::uint8_t>{0, 0, 0, 3};
    expected.insert(expected.end(), length.begin(), length.end());
    expected.insert(expected.end(), {'a', 'b', 0, 0});  // the NUL, then padding to the int32
    const std::vector<std::uint8_t> minus_two =
        little ? std::vector<std::uint8_t>{0xFE, 0xFF, 0xFF, 0xFF} : std::vector<std::uint8_t>{0xFF, 0xFF, 0xFF, 0xFE};
    expected.insert(expected.end(), minus_two.begin(), minus_two.end());
    EXPECT_EQ(bytes, expected) << little;

    cdr::Reader r(bytes.data(), bytes.size(), "msg");
    EXPECT_EQ(r.little_endian(), little);
    EXPECT_EQ(r.value<std::uint8_t>("a"), 7);
    EXPECT_EQ(r.value<double>("b"), 1.5);
    EXPECT_EQ(r.string("c"), "ab");
    EXPECT_EQ(r.value<std::int32_t>("d"), -2);
    EXPECT_EQ(r.left(), 0u);
    EXPECT_NO_THROW(r.expect_end("test"));
  }
}

TEST(Cdr, HostileLengthsAndHeadersAreErrors) {
  // A sequence that claims more elements than the message holds: an error before anything is allocated.
  cdr::Writer w;
  w.sequence_length(1000000000);
  w.value<double>(0.0);
  const std::vector<std::uint8_t> sequence = w.take();
  cdr::Reader r(sequence.data(), sequence.size(), "cloud");
  EXPECT_EQ(error_of([&] { r.sequence_length("data", 1); }),
            "cloud: data holds 1000000000 elements of at least 1 bytes, more than the 12 bytes left in the message");

  cdr::Writer s;
  s.value<std::uint32_t>(5);
  s.raw(reinterpret_cast<const std::uint8_t*>("abcde"), 5);  // no NUL
  const std::vector<std::uint8_t> unterminated = s.take();
  cdr::Reader rs(unterminated.data(), unterminated.size(), "m");
  EXPECT_EQ(error_of([&] { rs.string("frame_id"); }), "m: frame_id is not terminated by a NUL");

  const std::vector<std::uint8_t> xcdr2 = {0x00, 0x11, 0, 0, 1, 2, 3, 4};
  EXPECT_NE(error_of([&] { cdr::Reader(xcdr2.data(), xcdr2.size(), "m"); }).find("encapsulation 0x0011 (CDR2"),
            std::string::npos);
  const std::vector<std::uint8_t> short_header = {0x00};
  EXPECT_NE(error_of([&] { cdr::Reader(short_header.data(), short_header.size(), "m"); }).find("truncated"),
            std::string::npos);

  // Up to 3 bytes of padding may follow the last field; more is another message type.
  const std::vector<std::uint8_t> padded = {0, 1, 0, 3, 9, 0, 0, 0};
  cdr::Reader rp(padded.data(), padded.size(), "m");
  rp.value<std::uint8_t>("x");
  EXPECT_NO_THROW(rp.expect_end("T"));
  const std::vector<std::uint8_t> longer = {0, 1, 0, 0, 9, 0, 0, 0, 0};
  cdr::Reader rl(longer.data(), longer.size(), "m");
  rl.value<std::uint8_t>("x");
  EXPECT_EQ(error_of([&] { rl.expect_end("T"); }), "m: 4 bytes left over after a T message (not of that type?)");
  // Alignment padding must be in the message too.
  const std::vector<std::uint8_t> cut = {0, 1, 0, 0, 9, 0};
  cdr::Reader rc(cut.data(), cut.size(), "m");
  rc.value<std::uint8_t>("x");
  EXPECT_NE(error_of([&] { rc.value<std::uint32_t>("y"); }).find("truncated"), std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl
