#include "ply_format.hpp"

#include <charconv>
#include <sstream>
#include <utility>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::io {

bool ply_type_of(std::string_view name, PlyType& type) {
  static const std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUInt8},
      {"uint8", PlyType::kUInt8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUInt16},  {"uint16", PlyType::kUInt16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUInt32},     {"uint32", PlyType::kUInt32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, t] : kNames) {
    if (n == name) {
      type = t;
      return true;
    }
  }
  return false;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUInt8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUInt16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUInt32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

double ply_value(PlyType t, const unsigned char* p, bool le) {
  switch (t) {
    case PlyType::kInt8:
      return static_cast<std::int8_t>(*p);
    case PlyType::kUInt8:
      return *p;
    case PlyType::kInt16:
      return load<std::int16_t>(p, le);
    case PlyType::kUInt16:
      return load<std::uint16_t>(p, le);
    case PlyType::kInt32:
      return load<std::int32_t>(p, le);
    case PlyType::kUInt32:
      return load<std::uint32_t>(p, le);
    case PlyType::kFloat32:
      return load<float>(p, le);
    case PlyType::kFloat64:
      return load<double>(p, le);
  }
  return 0.0;
}

PlyHeader parse_ply_header(const std::function<bool(std::string&)>& next_line, const std::string& name,
                           std::uint64_t max_rows) {
  PlyHeader header;
  bool have_format = false, header_done = false;
  std::string line;
  for (std::size_t line_no = 1; next_line(line); ++line_no) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string key;
    words >> key;
    const std::string here = name + ":" + std::to_string(line_no) + ": ";
    auto word = [&words] {
      std::string w;
      words >> w;
      return w;
    };
    if (line_no == 1) {
      if (key != "ply") throw Error(name + ": not a PLY file (does not start with 'ply')");
      continue;
    }
    if (key.empty() || key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      header_done = true;
      break;
    }
    if (key == "format") {
      const std::string f = word();
      if (f == "ascii")
        header.format = PlyFormat::kAscii;
      else if (f == "binary_little_endian")
        header.format = PlyFormat::kBinaryLittle;
      else if (f == "binary_big_endian")
        header.format = PlyFormat::kBinaryBig;
      else
        throw Error(here + "unknown PLY format '" + f + "'");
      have_format = true;
    } else if (key == "element") {
      PlyElement e;
      e.name = word();
      std::string count = word();
      if (!count.empty() && count.front() == '+') count.erase(0, 1);
      long long n = -1;
      const auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), n);
      if (e.name.empty() || count.empty() || ec != std::errc() || end != count.data() + count.size() || n < 0) {
        throw Error(here + "malformed PLY element line");
      }
      if (static_cast<std::uint64_t>(n) > max_rows) {
        throw Error(here + "PLY element " + e.name + " has " + std::to_string(n) + " rows, more than the limit of " +
                    std::to_string(max_rows));
      }
      e.count = static_cast<std::size_t>(n);
      header.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (header.elements.empty()) throw Error(here + "PLY property before any element");
      PlyProperty p;
      std::string type = word();
      if (type == "list") {
        p.is_list = true;
        if (!ply_type_of(word(), p.count_type)) throw Error(here + "unknown PLY list count type");
        type = word();
      }
      if (!ply_type_of(type, p.type)) throw Error(here + "unknown PLY property type '" + type + "'");
      p.name = word();
      if (p.name.empty()) throw Error(here + "PLY property without a name");
      header.elements.back().properties.push_back(std::move(p));
    } else {
      throw Error(here + "unexpected PLY header line '" + line + "'");
    }
  }
  if (!header_done) throw Error(name + ": PLY header has no 'end_header' (truncated)");
  if (!have_format) throw Error(name + ": PLY header has no 'format' line");
  return header;
}

}  // namespace tsdf_mcl::io
