#pragma once
// CDR as ROS 2's message layouts put a message on the wire, written by hand for the wire-format test: XCDR1, little
// endian (RTPS 2.5, 10.5: the encapsulation header 00 01 00 00, CDR_LE), then the fields in the order of the .msg
// file, each aligned to its own size (8 for float64 and 64-bit integers, 4 for 32-bit ones and for the lengths of
// strings and sequences) counted from the end of the header; a string as its length counting the NUL, its bytes and
// the NUL; a sequence as its length and its elements; a fixed array as its elements; a bool as one byte. The payload
// is padded to a multiple of 4 and the padding counted in the header's last byte (RTPS 2.5, 10.5: "options").
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace tsdf_mcl::ros2_node::test {

class CdrBytes {
 public:
  CdrBytes() : bytes_{0x00, 0x01, 0x00, 0x00} {}
  CdrBytes& u8(std::uint8_t v) { return raw(&v, 1, 1); }
  CdrBytes& boolean(bool v) { return u8(v ? 1 : 0); }
  CdrBytes& u32(std::uint32_t v) { return raw(&v, 4, 4); }
  CdrBytes& i32(std::int32_t v) { return raw(&v, 4, 4); }
  CdrBytes& u64(std::uint64_t v) { return raw(&v, 8, 8); }
  CdrBytes& i64(std::int64_t v) { return raw(&v, 8, 8); }
  CdrBytes& f64(double v) { return raw(&v, 8, 8); }
  CdrBytes& string(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
    return *this;
  }
  CdrBytes& length(std::size_t n) { return u32(static_cast<std::uint32_t>(n)); }
  // The message as sent: padded to 4 bytes, the padding named in the header.
  std::vector<std::uint8_t> message() const {
    std::vector<std::uint8_t> out = bytes_;
    const std::size_t pad = (4 - (out.size() - 4) % 4) % 4;
    out.insert(out.end(), pad, 0);
    out[3] = static_cast<std::uint8_t>(pad);
    return out;
  }

 private:
  // Little endian on this machine (x86-64, aarch64), as the header says.
  CdrBytes& raw(const void* v, std::size_t size, std::size_t alignment) {
    while ((bytes_.size() - 4) % alignment != 0) bytes_.push_back(0);
    const auto* b = static_cast<const std::uint8_t*>(v);
    bytes_.insert(bytes_.end(), b, b + size);
    return *this;
  }
  std::vector<std::uint8_t> bytes_;
};

}  // namespace tsdf_mcl::ros2_node::test
