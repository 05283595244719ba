#include "tsdf_mcl/io/cdr.hpp"

#include <limits>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::cdr {
namespace {

// What a representation id other than plain CDR is, for the error (DDS-XTypes 1.3, 7.6.3.1.2).
std::string representation_name(std::uint8_t first, std::uint8_t second) {
  if (first != 0) return "not CDR";
  switch (second) {
    case 0x02:
    case 0x03:
      return "PL_CDR, a parameter list";
    case 0x10:
    case 0x11:
      return "CDR2, XCDR version 2";
    case 0x12:
    case 0x13:
      return "PL_CDR2, XCDR version 2";
    case 0x14:
    case 0x15:
      return "D_CDR2, XCDR version 2";
    default:
      return "unknown";
  }
}

char hex_digit(unsigned v) { return "0123456789abcdef"[v & 15u]; }

}  // namespace

Reader::Reader(const std::uint8_t* data, std::size_t size, std::string what)
    : data_(data), size_(size), what_(std::move(what)) {
  if (size < kEncapsulationBytes) {
    throw Error(what_ + ": message truncated: " + std::to_string(size) + " bytes, less than its CDR header");
  }
  if (data[0] != 0 || (data[1] != kCdrBigEndian && data[1] != kCdrLittleEndian)) {
    const std::string id = {
        '0', 'x', hex_digit(data[0] >> 4), hex_digit(data[0]), hex_digit(data[1] >> 4), hex_digit(data[1])};
    throw Error(what_ + ": encapsulation " + id + " (" + representation_name(data[0], data[1]) +
                "): only plain CDR (XCDR version 1, 0x0000 or 0x0001) is read");
  }
  little_endian_ = data[1] == kCdrLittleEndian;
}

void Reader::need(std::uint64_t bytes, const char* item) const {
  if (bytes > left()) {
    throw Error(what_ + ": message truncated: " + item + " needs " + std::to_string(bytes) + " bytes, " +
                std::to_string(left()) + " left");
  }
}

void Reader::align(std::size_t bytes) {
  const std::size_t offset = (pos_ - kEncapsulationBytes) % bytes;
  if (offset == 0) return;
  need(bytes - offset, "alignment");
  pos_ += bytes - offset;
}

std::string Reader::string(const char* item) {
  const std::uint32_t length = value<std::uint32_t>(item);
  if (length == 0) return {};  // not what rmw writes (it counts the NUL), but unambiguous
  need(length, item);
  const char* chars = reinterpret_cast<const char*>(data_ + pos_);
  if (chars[length - 1] != '\0') throw Error(what_ + ": " + item + " is not terminated by a NUL");
  pos_ += length;
  return {chars, length - 1};
}

std::uint32_t Reader::sequence_length(const char* item, std::size_t min_element_bytes) {
  const std::uint32_t n = value<std::uint32_t>(item);
  if (std::uint64_t{n} * min_element_bytes > left()) {
    throw Error(what_ + ": " + item + " holds " + std::to_string(n) + " elements of at least " +
                std::to_string(min_element_bytes) + " bytes, more than the " + std::to_string(left()) +
                " bytes left in the message");
  }
  return n;
}

std::size_t Reader::skip(std::uint64_t bytes, const char* item) {
  need(bytes, item);
  const std::size_t at = pos_;
  pos_ += static_cast<std::size_t>(bytes);
  return at;
}

void Reader::expect_end(const char* type) const {
  if (left() > 3) {
    throw Error(what_ + ": " + std::to_string(left()) + " bytes left over after a " + type +
                " message (not of that type?)");
  }
}

Writer::Writer(bool little_endian)
    : bytes_{0, little_endian ? kCdrLittleEndian : kCdrBigEndian, 0, 0}, little_endian_(little_endian) {}

void Writer::align(std::size_t bytes) {
  const std::size_t offset = (bytes_.size() - kEncapsulationBytes) % bytes;
  if (offset != 0) bytes_.resize(bytes_.size() + bytes - offset, 0);
}

void Writer::sequence_length(std::size_t n) {
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    throw Error("a CDR sequence holds at most 2^32 - 1 elements, not " + std::to_string(n));
  }
  value<std::uint32_t>(static_cast<std::uint32_t>(n));
}

void Writer::string(const std::string& s) {
  sequence_length(s.size() + 1);
  raw(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  bytes_.push_back(0);
}

void Writer::raw(const std::uint8_t* data, std::size_t size) { bytes_.insert(bytes_.end(), data, data + size); }

}  // namespace tsdf_mcl::cdr
