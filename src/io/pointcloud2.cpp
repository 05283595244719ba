#include "tsdf_mcl/io/pointcloud2.hpp"

#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {

std::size_t point_field_size(std::uint8_t datatype) {
  switch (datatype) {
    case kPointInt8:
    case kPointUint8:
      return 1;
    case kPointInt16:
    case kPointUint16:
      return 2;
    case kPointInt32:
    case kPointUint32:
    case kPointFloat32:
      return 4;
    case kPointFloat64:
      return 8;
    default:
      return 0;
  }
}

std::string point_field_type_name(std::uint8_t datatype) {
  static const char* const kNames[] = {"INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32", "FLOAT32", "FLOAT64"};
  if (datatype >= 1 && datatype <= 8) return kNames[datatype - 1];
  return "unknown type " + std::to_string(datatype);
}

namespace {

// One field read from a point's bytes as double.
struct FieldReader {
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  bool little_endian = true;

  double read(const std::uint8_t* point) const {
    const unsigned char* p = point + offset;
    switch (datatype) {
      case kPointInt8:
        return static_cast<std::int8_t>(p[0]);
      case kPointUint8:
        return p[0];
      case kPointInt16:
        return io::load<std::int16_t>(p, little_endian);
      case kPointUint16:
        return io::load<std::uint16_t>(p, little_endian);
      case kPointInt32:
        return io::load<std::int32_t>(p, little_endian);
      case kPointUint32:
        return io::load<std::uint32_t>(p, little_endian);
      case kPointFloat32:
        return io::load<float>(p, little_endian);
      default:
        return io::load<double>(p, little_endian);
    }
  }
};

// A double as float; nullopt where it is not finite or beyond float's range (converting it would be undefined).
std::optional<float> as_float(double v) {
  if (!std::isfinite(v) || std::abs(v) > static_cast<double>(FLT_MAX)) return std::nullopt;
  return static_cast<float>(v);
}

// The fields decode_pointcloud2 reads; x, y and z are always there once used_fields returns.
struct UsedFields {
  std::optional<FieldReader> x, y, z, intensity;
};

// The fields we use, each named once, of a known type, within point_step.
UsedFields used_fields(const PointCloud2Layout& layout, bool little_endian, const std::string& what) {
  UsedFields u;
  std::optional<FieldReader>&x = u.x, &y = u.y, &z = u.z, &intensity = u.intensity;
  for (const PointField& f : layout.fields) {
    std::optional<FieldReader>* slot = f.name == "x"           ? &x
                                       : f.name == "y"         ? &y
                                       : f.name == "z"         ? &z
                                       : f.name == "intensity" ? &intensity
                                                               : nullptr;
    if (!slot) continue;
    if (*slot) throw Error(what + ": PointCloud2 has two fields named '" + f.name + "'");
    const std::size_t bytes = point_field_size(f.datatype);
    if (bytes == 0) {
      throw Error(what + ": PointCloud2 field '" + f.name + "' has datatype " + std::to_string(f.datatype) +
                  " (not a sensor_msgs/PointField type 1..8)");
    }
    // Count 0 is no value at all; an array (count > 1, the first element is read) must fit in the point.
    if (f.count == 0) {
      throw Error(what + ": PointCloud2 field '" + f.name + "' has count 0 (no value; x, y, z and intensity need 1)");
    }
    if (std::uint64_t{f.offset} + bytes * std::uint64_t{f.count} > layout.point_step) {
      throw Error(what + ": PointCloud2 field '" + f.name + "' (" +
                  (f.count > 1 ? std::to_string(f.count) + " x " : std::string()) + point_field_type_name(f.datatype) +
                  " at offset " + std::to_string(f.offset) + ") does not fit in point_step " +
                  std::to_string(layout.point_step));
    }
    *slot = FieldReader{f.offset, f.datatype, little_endian};
  }
  std::string missing;
  for (const auto& [name, field] : {std::pair{"x", &x}, std::pair{"y", &y}, std::pair{"z", &z}}) {
    if (!*field) missing += missing.empty() ? name : std::string(", ") + name;
  }
  if (!missing.empty()) {
    std::string names;
    for (const PointField& f : layout.fields) names += (names.empty() ? "" : " ") + f.name;
    throw Error(what + ": PointCloud2 has no field " + missing + " (its fields: " + (names.empty() ? "none" : names) +
                ")");
  }
  for (const auto& [name, field] : {std::pair{"x", &x}, std::pair{"y", &y}, std::pair{"z", &z}}) {
    const std::uint8_t type = (*field)->datatype;
    if (type != kPointFloat32 && type != kPointFloat64) {
      throw Error(what + ": PointCloud2 field '" + name + "' is " + point_field_type_name(type) +
                  " (x, y and z must be FLOAT32 or FLOAT64)");
    }
  }
  return u;
}

// Sizes, checked before anything is read or allocated. Returns the number of points (width * height).
std::uint64_t checked_point_count(const PointCloud2Layout& layout, std::size_t size, const std::string& what) {
  const std::uint64_t points = io::checked_mul(layout.width, layout.height, what + ": PointCloud2 width * height");
  if (points > limits::kMaxScanPoints) {
    throw Error(what + ": PointCloud2 of " + std::to_string(layout.width) + " x " + std::to_string(layout.height) +
                " points is more than the limit of " + std::to_string(limits::kMaxScanPoints) + " points per scan");
  }
  const std::uint64_t row_bytes =
      io::checked_mul(layout.width, layout.point_step, what + ": PointCloud2 width * point_step");
  // A single row's row_step is not used to read it, but one below its own points' bytes means a corrupt message.
  if (points > 0 && layout.row_step < row_bytes) {
    throw Error(what + ": PointCloud2 row_step " + std::to_string(layout.row_step) + " is less than width " +
                std::to_string(layout.width) + " * point_step " + std::to_string(layout.point_step));
  }
  if (points > 0) {
    // The last row needs only its points; rows before it row_step bytes each.
    const std::uint64_t needed =
        io::checked_add(io::checked_mul(layout.height - 1u, layout.row_step, what + ": PointCloud2 row_step * height"),
                        row_bytes, what + ": PointCloud2 data size");
    if (needed > size) {
      throw Error(what + ": PointCloud2 data holds " + std::to_string(size) + " bytes, but " +
                  std::to_string(layout.height) + " rows of " + std::to_string(layout.width) + " points (" +
                  std::to_string(layout.point_step) + " bytes each, rows " + std::to_string(layout.row_step) +
                  " bytes apart) need " + std::to_string(needed));
    }
  }
  return points;
}

// Every point with finite x, y and z; the others are counted in *dropped.
PointCloud read_points(const PointCloud2Layout& layout, const std::uint8_t* data, std::uint64_t points,
                       const UsedFields& u, bool little_endian, std::size_t* dropped_out) {
  const std::optional<FieldReader>&x = u.x, &y = u.y, &z = u.z, &intensity = u.intensity;
  PointCloud cloud;
  cloud.points.reserve(static_cast<std::size_t>(points));
  if (intensity) cloud.intensity.reserve(static_cast<std::size_t>(points));
  std::size_t dropped = 0;
  // The common layout (float32 x y z, host byte order) without the per-field type switch.
  const bool fast = x->datatype == kPointFloat32 && y->datatype == kPointFloat32 && z->datatype == kPointFloat32 &&
                    little_endian == io::kHostIsLittleEndian;
  for (std::uint32_t row = 0; row < layout.height && points > 0; ++row) {
    const std::uint8_t* row_start = data + std::size_t{row} * layout.row_step;
    for (std::uint32_t col = 0; col < layout.width; ++col) {
      const std::uint8_t* point = row_start + std::size_t{col} * layout.point_step;
      Eigen::Vector3f p;
      bool finite = true;
      if (fast) {
        std::memcpy(&p.x(), point + x->offset, 4);
        std::memcpy(&p.y(), point + y->offset, 4);
        std::memcpy(&p.z(), point + z->offset, 4);
        finite = p.allFinite();
      } else {
        const FieldReader* readers[3] = {&*x, &*y, &*z};
        for (int a = 0; a < 3 && finite; ++a) {
          const std::optional<float> v = as_float(readers[a]->read(point));
          if (v)
            p[a] = *v;
          else
            finite = false;
        }
      }
      if (!finite) {
        ++dropped;
        continue;
      }
      cloud.points.push_back(p);
      if (intensity) cloud.intensity.push_back(as_float(intensity->read(point)).value_or(0.0f));
    }
  }
  *dropped_out = dropped;
  return cloud;
}

}  // namespace

PointCloud decode_pointcloud2(const PointCloud2Layout& layout, const std::uint8_t* data, std::size_t size,
                              PointCloud2Stats* stats, const std::string& what) {
  const bool little_endian = !layout.is_bigendian;
  const UsedFields fields = used_fields(layout, little_endian, what);
  const std::uint64_t points = checked_point_count(layout, size, what);
  std::size_t dropped = 0;
  PointCloud cloud = read_points(layout, data, points, fields, little_endian, &dropped);
  if (stats) {
    stats->points = static_cast<std::size_t>(points);
    stats->dropped_non_finite = dropped;
  }
  return cloud;
}

EncodedPointCloud2 encode_pointcloud2(const PointCloud& cloud, const std::vector<std::uint16_t>* rings) {
  if (!cloud.intensity.empty() && cloud.intensity.size() != cloud.size()) {
    throw Error("encode_pointcloud2: " + std::to_string(cloud.intensity.size()) + " intensities for " +
                std::to_string(cloud.size()) + " points");
  }
  if (rings && rings->size() != cloud.size()) {
    throw Error("encode_pointcloud2: " + std::to_string(rings->size()) + " rings for " + std::to_string(cloud.size()) +
                " points");
  }
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max() / 32) {
    throw Error("encode_pointcloud2: " + std::to_string(cloud.size()) + " points do not fit in one PointCloud2");
  }
  EncodedPointCloud2 out;
  PointCloud2Layout& l = out.layout;
  l.height = 1;
  l.width = static_cast<std::uint32_t>(cloud.size());
  l.fields = {{"x", 0, kPointFloat32, 1},
              {"y", 4, kPointFloat32, 1},
              {"z", 8, kPointFloat32, 1},
              {"intensity", 12, kPointFloat32, 1}};
  l.point_step = 16;
  if (rings) {
    l.fields.push_back({"ring", 16, kPointUint16, 1});
    l.point_step = 18;
  }
  l.row_step = l.width * l.point_step;
  l.is_bigendian = false;
  l.is_dense = true;
  for (const Eigen::Vector3f& p : cloud.points) l.is_dense = l.is_dense && p.allFinite();
  std::string bytes;
  bytes.reserve(l.row_step);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) io::append_le(bytes, cloud.points[i][a]);
    io::append_le(bytes, cloud.intensity.empty() ? 0.0f : cloud.intensity[i]);
    if (rings) io::append_le(bytes, (*rings)[i]);
  }
  out.data.assign(bytes.begin(), bytes.end());
  return out;
}

}  // namespace tsdf_mcl
