#pragma once
// sensor_msgs/PointCloud2 to PointCloud, without ROS: the layout fields of the message (height, width, fields,
// is_bigendian, point_step, row_step, is_dense) and its data bytes in, the points of the scan out. Always built, so
// that it is tested and fuzzed where no ROS package is installed; the bag reader (Dataset::open_bag) feeds it.
//
// What it reads: x, y and z as FLOAT32 or FLOAT64 at any offsets within point_step (each field once, count 1 or
// more, all elements within point_step: the first is read; count 0 is an error), `intensity` of any numeric type where
// the message has it; every other field (ring, t/time, reflectivity, ...) is ignored. Organized clouds (height > 1) are
// read row by row, rows row_step bytes apart (row padding allowed), big-endian data is swapped. Points with a NaN or
// infinite coordinate are dropped and counted (organized Ouster / Velodyne clouds mark missing returns so).
//
// Every size field is hostile input: width * height and row_step * (height - 1) + width * point_step are computed
// with checked arithmetic and compared with the data's length before a byte is read; a field must lie within
// point_step and rows within row_step. Anything inconsistent is an Error with one sentence naming the field.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tsdf_mcl/core/point_cloud.hpp"

namespace tsdf_mcl {

// sensor_msgs/PointField.datatype.
enum PointFieldType : std::uint8_t {
  kPointInt8 = 1,
  kPointUint8 = 2,
  kPointInt16 = 3,
  kPointUint16 = 4,
  kPointInt32 = 5,
  kPointUint32 = 6,
  kPointFloat32 = 7,
  kPointFloat64 = 8,
};
// Bytes of one element of the type; 0 for an unknown type.
std::size_t point_field_size(std::uint8_t datatype);
// "FLOAT32", ...; "unknown type N" otherwise.
std::string point_field_type_name(std::uint8_t datatype);

struct PointField {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 1;
};

// sensor_msgs/PointCloud2 less its header and data.
struct PointCloud2Layout {
  std::uint32_t height = 0;  // 1 for an unorganized cloud
  std::uint32_t width = 0;
  std::vector<PointField> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0;  // bytes per point
  std::uint32_t row_step = 0;    // bytes per row (>= width * point_step)
  bool is_dense = false;
};

struct PointCloud2Stats {
  std::size_t points = 0;              // width * height
  std::size_t dropped_non_finite = 0;  // of those, dropped for a NaN or infinite coordinate
};

// Decodes `size` bytes at `data` laid out as `layout`. `what` starts every error message (e.g. "run.bag: /points
// message 12"). Without an intensity field the result's intensity is empty. Throws Error for a layout that does
// not fit the data, missing or non-float x/y/z, or more than limits::kMaxScanPoints points.
PointCloud decode_pointcloud2(const PointCloud2Layout& layout, const std::uint8_t* data, std::size_t size,
                              PointCloud2Stats* stats = nullptr, const std::string& what = "PointCloud2");

// The other way, for writing bags: x y z intensity as FLOAT32 (intensity 0 where the cloud has none), plus a
// UINT16 `ring` field where `rings` is given (one per point), little-endian, unorganized (height 1), row_step =
// width * point_step.
struct EncodedPointCloud2 {
  PointCloud2Layout layout;
  std::vector<std::uint8_t> data;
};
EncodedPointCloud2 encode_pointcloud2(const PointCloud& cloud, const std::vector<std::uint16_t>* rings = nullptr);

}  // namespace tsdf_mcl
