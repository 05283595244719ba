#include "tsdf_mcl/io/ros1_messages.hpp"

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::ros1 {
namespace {

// Reads the ROS 1 wire format from a byte range; every read is checked against the bytes left.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size, const std::string& what) : data_(data), size_(size), what_(what) {}

  std::size_t position() const { return pos_; }
  std::size_t left() const { return size_ - pos_; }

  void need(std::uint64_t bytes, const char* item) const {
    if (bytes > left()) {
      throw Error(what_ + ": message truncated: " + item + " needs " + std::to_string(bytes) + " bytes, " +
                  std::to_string(left()) + " left");
    }
  }
  template <typename T>
  T value(const char* item) {
    need(sizeof(T), item);
    const T v = io::load<T>(data_ + pos_, true);
    pos_ += sizeof(T);
    return v;
  }
  std::uint32_t u32(const char* item) { return value<std::uint32_t>(item); }
  double f64(const char* item) { return msg::finite(value<double>(item), what_, item); }
  std::string string(const char* item) {
    const std::uint32_t length = u32(item);
    need(length, item);
    std::string s(reinterpret_cast<const char*>(data_ + pos_), length);
    pos_ += length;
    return s;
  }
  // The length of an array whose elements take at least `min_element_bytes` each, checked against what is left.
  std::uint32_t array_length(const char* item, std::size_t min_element_bytes) {
    const std::uint32_t n = u32(item);
    need(std::uint64_t{n} * min_element_bytes, item);
    return n;
  }
  void skip(std::size_t bytes, const char* item) {
    need(bytes, item);
    pos_ += bytes;
  }
  void expect_end(const char* type) const {
    if (left() != 0) {
      throw Error(what_ + ": " + std::to_string(left()) + " bytes left over after a " + type +
                  " message (not of that type?)");
    }
  }
  const std::string& what() const { return what_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  const std::string& what_;
};

Header read_header(Reader& r) {
  Header h;
  h.seq = r.u32("header.seq");
  h.sec = r.u32("header.stamp");
  h.nsec = r.u32("header.stamp");
  if (h.nsec >= 1000000000u)
    throw Error(r.what() + ": header.stamp has " + std::to_string(h.nsec) + " nanoseconds (at most 999999999)");
  h.frame_id = r.string("header.frame_id");
  return h;
}

Eigen::Vector3d read_vector3(Reader& r, const char* item) {
  const double x = r.f64(item), y = r.f64(item), z = r.f64(item);
  return {x, y, z};
}

Pose read_pose(Reader& r, const char* position, const char* orientation) {
  const Eigen::Vector3d t = read_vector3(r, position);
  const double x = r.f64(orientation), y = r.f64(orientation), z = r.f64(orientation), w = r.f64(orientation);
  return msg::pose_of(t, msg::unit_quaternion(x, y, z, w, r.what(), orientation));
}

constexpr std::size_t kHeaderMinBytes = 16;  // seq, stamp, an empty frame_id

}  // namespace

Header decode_header(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  return read_header(r);
}

PointCloud2Message decode_pointcloud2_message(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  PointCloud2Message m;
  m.header = read_header(r);
  m.layout.height = r.u32("height");
  m.layout.width = r.u32("width");
  // A field: name (4 + bytes), offset 4, datatype 1, count 4.
  const std::uint32_t fields = r.array_length("fields", 13);
  m.layout.fields.reserve(fields);
  for (std::uint32_t i = 0; i < fields; ++i) {
    PointField f;
    f.name = r.string("fields.name");
    f.offset = r.u32("fields.offset");
    f.datatype = r.value<std::uint8_t>("fields.datatype");
    f.count = r.u32("fields.count");
    m.layout.fields.push_back(std::move(f));
  }
  m.layout.is_bigendian = r.value<std::uint8_t>("is_bigendian") != 0;
  m.layout.point_step = r.u32("point_step");
  m.layout.row_step = r.u32("row_step");
  const std::uint32_t data_size = r.array_length("data", 1);
  m.data_offset = r.position();
  m.data_size = data_size;
  r.skip(data_size, "data");
  m.layout.is_dense = r.value<std::uint8_t>("is_dense") != 0;
  r.expect_end(kPointCloud2.name);
  return m;
}

std::vector<TransformStamped> decode_tf_message(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  // header, child_frame_id (4 + bytes), 7 doubles.
  const std::uint32_t n = r.array_length("transforms", kHeaderMinBytes + 4 + 56);
  std::vector<TransformStamped> out;
  out.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    TransformStamped t;
    t.header = read_header(r);
    t.child_frame_id = r.string("child_frame_id");
    t.transform = read_pose(r, "transform.translation", "transform.rotation");
    out.push_back(std::move(t));
  }
  r.expect_end(kTfMessage.name);
  return out;
}

PoseMessage decode_odometry(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  PoseMessage p;
  p.header = read_header(r);
  p.child_frame_id = r.string("child_frame_id");
  p.pose = read_pose(r, "pose.pose.position", "pose.pose.orientation");
  // pose.covariance (36 doubles), twist.twist (6), twist.covariance (36): read past, not checked.
  r.skip((36 + 6 + 36) * 8, "pose.covariance and twist");
  r.expect_end(kOdometry.name);
  return p;
}

PoseMessage decode_pose_stamped(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  PoseMessage p;
  p.header = read_header(r);
  p.pose = read_pose(r, "pose.position", "pose.orientation");
  r.expect_end(kPoseStamped.name);
  return p;
}

PoseMessage decode_pose_with_covariance_stamped(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  PoseMessage p;
  p.header = read_header(r);
  p.pose = read_pose(r, "pose.pose.position", "pose.pose.orientation");
  r.skip(36 * 8, "pose.covariance");  // read past, not checked
  r.expect_end(kPoseWithCovarianceStamped.name);
  return p;
}

Imu decode_imu(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Reader r(data, size, what);
  Imu m;
  m.header = read_header(r);
  // orientation (4 doubles, often all zero: unknown) and its covariance (9): not used.
  r.skip((4 + 9) * 8, "orientation");
  m.angular_velocity = read_vector3(r, "angular_velocity");
  r.skip(9 * 8, "angular_velocity_covariance");
  m.linear_acceleration = read_vector3(r, "linear_acceleration");
  r.skip(9 * 8, "linear_acceleration_covariance");
  r.expect_end(kImu.name);
  return m;
}

namespace {

void append_u32(std::string& out, std::uint32_t v) { io::append_le(out, v); }
void append_string(std::string& out, const std::string& s) {
  append_u32(out, static_cast<std::uint32_t>(s.size()));
  out += s;
}

}  // namespace

std::vector<std::uint8_t> encode_pointcloud2_message(const Header& header, const PointCloud2Layout& layout,
                                                     const std::vector<std::uint8_t>& data) {
  std::string out;
  append_u32(out, header.seq);
  append_u32(out, static_cast<std::uint32_t>(header.sec));
  append_u32(out, header.nsec);
  append_string(out, header.frame_id);
  append_u32(out, layout.height);
  append_u32(out, layout.width);
  append_u32(out, static_cast<std::uint32_t>(layout.fields.size()));
  for (const PointField& f : layout.fields) {
    append_string(out, f.name);
    append_u32(out, f.offset);
    out.push_back(static_cast<char>(f.datatype));
    append_u32(out, f.count);
  }
  out.push_back(layout.is_bigendian ? 1 : 0);
  append_u32(out, layout.point_step);
  append_u32(out, layout.row_step);
  append_u32(out, static_cast<std::uint32_t>(data.size()));
  out.append(reinterpret_cast<const char*>(data.data()), data.size());
  out.push_back(layout.is_dense ? 1 : 0);
  return {out.begin(), out.end()};
}

}  // namespace tsdf_mcl::ros1
