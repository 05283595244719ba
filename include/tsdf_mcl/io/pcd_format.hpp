#pragma once
// PCD v0.7 headers and payload encodings, shared by the scan reader (Dataset::load_scan) and the streaming map-cloud
// reader (CloudReader). Every header value is checked before it sizes memory or a loop.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace tsdf_mcl::io {

struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<std::uint64_t> sizes, counts;
  std::vector<char> types;
  std::uint64_t points = 0;
  std::optional<std::uint64_t> width, height;  // where given, width x height = points (height 1 if not given)
  std::string data;                            // ascii, binary or binary_compressed
  // Derived: byte offset of each field in a binary record, its first column in an ascii row, the record size.
  std::vector<std::size_t> offset, column;
  std::size_t stride = 0, columns = 0;
  int x = -1, y = -1, z = -1, intensity = -1;  // field numbers, -1 if absent
};

// Parses header lines (next_line returns false at the end of input) up to and including DATA. Coordinates must be
// float32 or float64, intensity float32. `max_points` bounds POINTS. Throws Error naming `name`.
PcdHeader parse_pcd_header(const std::function<bool(std::string&)>& next_line, const std::string& name,
                           std::uint64_t max_points);

// A coordinate of field `f` (float32 or float64, little-endian) at `bytes`.
double pcd_coordinate(const PcdHeader& h, int f, const unsigned char* bytes);

// LZF decompression (the codec of binary_compressed PCD): exactly `out_size` bytes must come out of `in`, and no
// back-reference may reach before the start of the output. Throws Error naming `name` otherwise.
// Checks a binary_compressed payload's sizes before the output is allocated: LZF turns a byte into at most 88
// (a 3-byte back-reference copies up to 264 bytes), so a small file cannot claim gigabytes; `max_unpacked` bounds it
// further. Throws Error naming `name`.
void check_lzf_sizes(std::uint64_t packed, std::uint64_t unpacked, std::uint64_t max_unpacked, const std::string& name);
void lzf_decompress(const unsigned char* in, std::size_t in_size, unsigned char* out, std::size_t out_size,
                    const std::string& name);

}  // namespace tsdf_mcl::io
