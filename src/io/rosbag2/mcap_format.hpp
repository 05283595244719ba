#pragma once
// The MCAP container (the specification of github.com/foxglove/mcap, website/docs/spec; major version 0):
//
//   <magic><Header><data section: records, possibly inside Chunks>[<DataEnd><summary section>]<Footer><magic>
//   a record: opcode (1 byte), content length (uint64), content
//
// little-endian integers; String = uint32 length + UTF-8 bytes; Map = uint32 byte length + entries. Records may be
// extended with fields at their end (readers skip what they do not know), except Message, DataEnd and Footer.
// FieldReader and FieldWriter read and write record contents for mcap_file.cpp and mcap_writer.cpp.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/little_endian.hpp"

namespace tsdf_mcl::rosbag2::mcap {

inline constexpr char kMagic[] = "\x89MCAP0\r\n";  // 8 bytes
inline constexpr std::size_t kMagicBytes = 8;
inline constexpr std::size_t kRecordHeaderBytes = 9;  // opcode, length
inline constexpr std::size_t kFooterContentBytes = 20;

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// A record's content, read field by field; every read is checked against the content's length.
class FieldReader {
 public:
  FieldReader(const std::uint8_t* data, std::uint64_t size, const std::string& what)
      : data_(data), size_(size), what_(what) {}

  std::uint64_t left() const { return size_ - pos_; }
  template <typename T>
  T value(const char* field) {
    need(sizeof(T), field);
    const T v = io::load<T>(data_ + pos_, true);
    pos_ += sizeof(T);
    return v;
  }
  std::string string(const char* field) {
    const std::pair<const std::uint8_t*, std::uint64_t> b = bytes(value<std::uint32_t>(field), field);
    return {reinterpret_cast<const char*>(b.first), static_cast<std::size_t>(b.second)};
  }
  std::pair<const std::uint8_t*, std::uint64_t> bytes(std::uint64_t n, const char* field) {
    need(n, field);
    const std::uint8_t* at = data_ + pos_;
    pos_ += n;
    return {at, n};
  }
  // The rest of the content (a Message's data).
  std::pair<const std::uint8_t*, std::uint64_t> rest() { return bytes(left(), "data"); }

 private:
  void need(std::uint64_t n, const char* field) const {
    if (n > left()) {
      throw Error(what_ + ": corrupt MCAP: " + field + " needs " + std::to_string(n) + " bytes, its record holds " +
                  std::to_string(left()) + " more");
    }
  }
  const std::uint8_t* data_;
  std::uint64_t size_;
  std::uint64_t pos_ = 0;
  const std::string& what_;
};

// Record contents, field by field.
class FieldWriter {
 public:
  template <typename T>
  FieldWriter& value(T v) {
    io::append_le(bytes_, v);
    return *this;
  }
  FieldWriter& string(const std::string& s) {
    value<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    bytes_ += s;
    return *this;
  }
  FieldWriter& raw(const std::string& s) {
    bytes_ += s;
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// A whole record: opcode, length, content.
inline std::string record(Opcode opcode, const std::string& content) {
  std::string out(1, static_cast<char>(opcode));
  io::append_le<std::uint64_t>(out, content.size());
  return out + content;
}

}  // namespace tsdf_mcl::rosbag2::mcap
