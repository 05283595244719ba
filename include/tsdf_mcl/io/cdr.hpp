#pragma once
// CDR as ROS 2 serializes messages (rmw_fastrtps and rmw_cyclonedds alike; what rosbag2 stores and DDS carries):
// OMG XCDR version 1, "plain CDR" (DDS-XTypes 1.3, 7.4.1; DDSI-RTPS 2.5, 10.2), in either byte order.
//
//   encapsulation header   4 bytes: representation id, big-endian on the wire (0x0000 CDR_BE, 0x0001 CDR_LE), then
//                          2 option bytes (their low 2 bits: padding bytes at the end of the message)
//   primitives             in the header's byte order, each aligned to its own size (1, 2, 4 or 8 bytes) counted
//                          from the end of the encapsulation header; bool and uint8 are one byte
//   string                 uint32 length including the terminating NUL, the bytes, the NUL
//   sequence T[]           uint32 element count, then the elements; arrays T[N] are the N elements alone
//   nested messages        their fields in order, no header of their own
//
// Reader checks every length against the bytes left before it allocates (a sequence longer than its message is an
// Error, never a huge allocation); Writer produces what rmw would. ros2_messages.hpp builds the message codecs on
// them; other ROS 2 code (a node's wire tests) can use them directly.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "tsdf_mcl/core/little_endian.hpp"

namespace tsdf_mcl::cdr {

inline constexpr std::size_t kEncapsulationBytes = 4;
inline constexpr std::uint8_t kCdrBigEndian = 0x00, kCdrLittleEndian = 0x01;  // the id's second byte (first: 0)

class Reader {
 public:
  // Reads the encapsulation header. Throws Error("WHAT: ...") for a message shorter than it or a representation
  // other than plain CDR (XCDR2 and parameter lists are named as such).
  Reader(const std::uint8_t* data, std::size_t size, std::string what);

  bool little_endian() const { return little_endian_; }
  std::size_t position() const { return pos_; }  // from the message's first byte, header included
  std::size_t left() const { return size_ - pos_; }
  const std::string& what() const { return what_; }

  // Moves to the next multiple of `bytes` (from the end of the header); the padding must be in the message.
  void align(std::size_t bytes);
  // Throws unless `bytes` more are left; `item` names the field in the error.
  void need(std::uint64_t bytes, const char* item) const;

  template <typename T>
  T value(const char* item) {
    static_assert(std::is_arithmetic_v<T>);
    align(sizeof(T));
    need(sizeof(T), item);
    const T v = io::load<T>(data_ + pos_, little_endian_);
    pos_ += sizeof(T);
    return v;
  }
  bool boolean(const char* item) { return value<std::uint8_t>(item) != 0; }
  std::string string(const char* item);
  // The element count of a sequence whose elements take at least `min_element_bytes` each, checked against what is
  // left (so a count can never ask for more than the message holds).
  std::uint32_t sequence_length(const char* item, std::size_t min_element_bytes);
  // The next `bytes` bytes, unaligned (the content of a uint8[] sequence); returns where they start.
  std::size_t skip(std::uint64_t bytes, const char* item);
  // Throws unless the message ends here, but for the 0..3 padding bytes CDR allows after the last field.
  void expect_end(const char* type) const;

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = kEncapsulationBytes;
  bool little_endian_ = true;
  std::string what_;
};

class Writer {
 public:
  // Starts the message with its encapsulation header: CDR_LE (the usual) or CDR_BE.
  explicit Writer(bool little_endian = true);

  void align(std::size_t bytes);
  template <typename T>
  void value(T v) {
    static_assert(std::is_arithmetic_v<T>);
    align(sizeof(T));
    if (little_endian_ != io::kHostIsLittleEndian) v = io::byte_swapped(v);
    const std::size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &v, sizeof(T));
  }
  void boolean(bool v) { value<std::uint8_t>(v ? 1 : 0); }
  void string(const std::string& s);
  void sequence_length(std::size_t n);  // throws past 2^32 - 1
  void raw(const std::uint8_t* data, std::size_t size);
  std::vector<std::uint8_t> take() { return std::move(bytes_); }

 private:
  std::vector<std::uint8_t> bytes_;
  bool little_endian_;
};

}  // namespace tsdf_mcl::cdr
