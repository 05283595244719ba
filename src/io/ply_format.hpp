#pragma once
// PLY headers and binary values, shared by the mesh loader (whole files) and the streaming map-cloud reader.
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace tsdf_mcl::io {

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };
enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

bool ply_type_of(std::string_view name, PlyType& type);
std::size_t ply_size(PlyType t);
// A binary value of type `t` at `bytes`.
double ply_value(PlyType t, const unsigned char* bytes, bool little_endian);

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUInt8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
};

// Parses header lines (next_line returns false at the end of input) up to and including end_header. Element counts
// above `max_rows` are errors. Throws Error naming `name` and the line.
PlyHeader parse_ply_header(const std::function<bool(std::string&)>& next_line, const std::string& name,
                           std::uint64_t max_rows);

}  // namespace tsdf_mcl::io
