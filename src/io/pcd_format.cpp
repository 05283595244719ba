#include "tsdf_mcl/io/pcd_format.hpp"

#include <charconv>
#include <sstream>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::io {
namespace {

// One non-negative integer of a PCD header, bounded.
std::uint64_t pcd_count(const std::string& token, std::uint64_t max, const std::string& name, const std::string& key) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (token.empty() || ec != std::errc() || end != token.data() + token.size() || value > max) {
    throw Error(name + ": PCD " + key + " '" + token + "' is not an integer in 0.." + std::to_string(max));
  }
  return value;
}

// One header line's values by its key; unknown keys (VERSION, VIEWPOINT) are skipped.
void read_pcd_header_line(PcdHeader& h, const std::string& key, const std::vector<std::string>& values,
                          const std::string& name, std::uint64_t max_points, bool& have_points) {
  constexpr std::uint64_t kMaxCount = 4096;
  if (key == "FIELDS") {
    h.fields = values;
  } else if (key == "SIZE") {
    h.sizes.clear();
    for (const auto& v : values) {
      h.sizes.push_back(pcd_count(v, 8, name, "SIZE"));
      if (h.sizes.back() != 1 && h.sizes.back() != 2 && h.sizes.back() != 4 && h.sizes.back() != 8) {
        throw Error(name + ": PCD SIZE " + v + " (must be 1, 2, 4 or 8 bytes)");
      }
    }
  } else if (key == "TYPE") {
    h.types.clear();
    for (const auto& v : values) {
      if (v != "F" && v != "I" && v != "U") throw Error(name + ": PCD TYPE '" + v + "' (must be F, I or U)");
      h.types.push_back(v[0]);
    }
  } else if (key == "COUNT") {
    h.counts.clear();
    for (const auto& v : values) {
      h.counts.push_back(pcd_count(v, kMaxCount, name, "COUNT"));
      if (h.counts.back() == 0) throw Error(name + ": PCD COUNT 0 (every field has at least one element)");
    }
  } else if (key == "POINTS") {
    if (values.size() != 1) throw Error(name + ": PCD POINTS needs one value");
    h.points = pcd_count(values[0], max_points, name, "POINTS");
    have_points = true;
  } else if (key == "WIDTH" || key == "HEIGHT") {
    // POINTS counts the points; WIDTH x HEIGHT must agree with it (lay_out_pcd_fields), or the header is corrupt.
    if (values.size() != 1) throw Error(name + ": PCD " + key + " needs one value");
    (key == "WIDTH" ? h.width : h.height) = pcd_count(values[0], max_points, name, key);
  } else if (key == "DATA") {
    if (values.size() != 1) throw Error(name + ": PCD DATA needs one value");
    h.data = values[0];
  }
}

// The header's fields checked against each other, then each one's offset and column in a point.
void lay_out_pcd_fields(PcdHeader& h, const std::string& name, bool have_points) {
  if (h.counts.empty()) h.counts.assign(h.fields.size(), 1);
  if (h.fields.empty() || h.sizes.size() != h.fields.size() || h.types.size() != h.fields.size() ||
      h.counts.size() != h.fields.size()) {
    throw Error(name + ": malformed PCD header (FIELDS, SIZE, TYPE and COUNT must name the same fields)");
  }
  if (!have_points) throw Error(name + ": PCD header has no POINTS line");
  if (h.width || h.height) {
    const std::uint64_t w = h.width.value_or(h.points), ht = h.height.value_or(1);
    const bool agree = w == 0 || ht == 0 ? h.points == 0 : h.points % w == 0 && h.points / w == ht;
    if (!agree) {
      throw Error(name + ": PCD WIDTH x HEIGHT (" + std::to_string(w) + " x " + std::to_string(ht) +
                  ") differs from POINTS " + std::to_string(h.points));
    }
  }
  if (h.data.empty()) throw Error(name + ": PCD header has no DATA line");
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed") {
    throw Error(name + ": PCD DATA '" + h.data + "' not supported (ascii, binary or binary_compressed)");
  }
  h.offset.resize(h.fields.size());
  h.column.resize(h.fields.size());
  for (std::size_t f = 0; f < h.fields.size(); ++f) {
    // At most 256 fields * 4096 elements * 8 bytes: no overflow.
    h.offset[f] = h.stride;
    h.column[f] = h.columns;
    h.stride += h.sizes[f] * h.counts[f];
    h.columns += h.counts[f];
    if (h.fields[f] == "x") h.x = static_cast<int>(f);
    if (h.fields[f] == "y") h.y = static_cast<int>(f);
    if (h.fields[f] == "z") h.z = static_cast<int>(f);
    if (h.fields[f] == "intensity") h.intensity = static_cast<int>(f);
  }
  if (h.x < 0 || h.y < 0 || h.z < 0) throw Error(name + ": PCD has no x y z fields");
  for (int f : {h.x, h.y, h.z}) {
    const auto i = static_cast<std::size_t>(f);
    if (h.types[i] != 'F' || (h.sizes[i] != 4 && h.sizes[i] != 8))
      throw Error(name + ": PCD x/y/z must be float32 or float64");
  }
  if (h.intensity >= 0 &&
      (h.types[static_cast<std::size_t>(h.intensity)] != 'F' || h.sizes[static_cast<std::size_t>(h.intensity)] != 4)) {
    throw Error(name + ": PCD intensity must be float32");
  }
}

}  // namespace

PcdHeader parse_pcd_header(const std::function<bool(std::string&)>& next_line, const std::string& name,
                           std::uint64_t max_points) {
  PcdHeader h;
  bool have_points = false;
  constexpr std::uint64_t kMaxFields = 256;
  for (std::string line; h.data.empty() && next_line(line);) {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    std::vector<std::string> values;
    for (std::string v; ss >> v;) {
      values.push_back(v);
      if (values.size() > kMaxFields)
        throw Error(name + ": PCD " + key + " has more than " + std::to_string(kMaxFields) + " values");
    }
    read_pcd_header_line(h, key, values, name, max_points, have_points);
  }
  lay_out_pcd_fields(h, name, have_points);
  return h;
}

double pcd_coordinate(const PcdHeader& h, int f, const unsigned char* bytes) {
  return h.sizes[static_cast<std::size_t>(f)] == 8 ? load<double>(bytes, true)
                                                   : static_cast<double>(load<float>(bytes, true));
}

void check_lzf_sizes(std::uint64_t packed, std::uint64_t unpacked, std::uint64_t max_unpacked,
                     const std::string& name) {
  if (unpacked > 88 * packed + 88) {
    throw Error(name + ": PCD binary_compressed header claims " + std::to_string(unpacked) + " bytes from " +
                std::to_string(packed) + " compressed ones (LZF expands at most 88 times): corrupt");
  }
  if (unpacked > max_unpacked) {
    throw Error(name + ": PCD binary_compressed payload of " + std::to_string(unpacked) +
                " bytes is more than the limit of " + std::to_string(max_unpacked));
  }
}

void lzf_decompress(const unsigned char* in, std::size_t in_size, unsigned char* out, std::size_t out_size,
                    const std::string& name) {
  const auto corrupt = [&name](const char* why) {
    return Error(name + ": corrupt binary_compressed PCD payload (" + std::string(why) + ")");
  };
  std::size_t i = 0, o = 0;
  while (i < in_size) {
    const std::size_t ctrl = in[i++];
    if (ctrl < 32) {  // a literal run of ctrl + 1 bytes
      const std::size_t n = ctrl + 1;
      if (n > in_size - i) throw corrupt("literal run past the end of the input");
      if (n > out_size - o) throw corrupt("more data than the header announces");
      for (std::size_t k = 0; k < n; ++k) out[o + k] = in[i + k];
      i += n;
      o += n;
      continue;
    }
    std::size_t n = ctrl >> 5;  // a back-reference of n + 2 bytes
    if (n == 7) {
      if (i >= in_size) throw corrupt("back-reference past the end of the input");
      n += in[i++];
    }
    n += 2;
    if (i >= in_size) throw corrupt("back-reference past the end of the input");
    const std::size_t distance = ((ctrl & 0x1f) << 8) + in[i++] + 1;
    if (distance > o) throw corrupt("back-reference before the start of the data");
    if (n > out_size - o) throw corrupt("more data than the header announces");
    // Byte by byte: the source may overlap what is being written (runs).
    for (std::size_t k = 0; k < n; ++k, ++o) out[o] = out[o - distance];
  }
  if (o != out_size) throw corrupt("less data than the header announces");
}

}  // namespace tsdf_mcl::io
