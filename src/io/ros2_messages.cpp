#include "tsdf_mcl/io/ros2_messages.hpp"

#include <limits>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/cdr.hpp"

namespace tsdf_mcl::ros2 {
namespace {

// The least bytes a header takes: stamp (8), an empty frame_id (4).
constexpr std::size_t kHeaderMinBytes = 12;

Header read_header(cdr::Reader& r) {
  Header h;
  h.sec = r.value<std::int32_t>("header.stamp.sec");
  h.nsec = r.value<std::uint32_t>("header.stamp.nanosec");
  if (h.nsec >= 1000000000u) {
    throw Error(r.what() + ": header.stamp has " + std::to_string(h.nsec) + " nanoseconds (at most 999999999)");
  }
  h.frame_id = r.string("header.frame_id");
  return h;
}

double read_f64(cdr::Reader& r, const char* item) { return msg::finite(r.value<double>(item), r.what(), item); }

Eigen::Vector3d read_vector3(cdr::Reader& r, const char* item) {
  const double x = read_f64(r, item), y = read_f64(r, item), z = read_f64(r, item);
  return {x, y, z};
}

Pose read_pose(cdr::Reader& r, const char* position, const char* orientation) {
  const Eigen::Vector3d t = read_vector3(r, position);
  const double x = read_f64(r, orientation), y = read_f64(r, orientation), z = read_f64(r, orientation),
               w = read_f64(r, orientation);
  return msg::pose_of(t, msg::unit_quaternion(x, y, z, w, r.what(), orientation));
}

// float64[N]: read past (covariances, twists), not checked.
void skip_doubles(cdr::Reader& r, std::size_t n, const char* item) {
  r.align(8);
  r.skip(n * 8, item);
}

void write_header(cdr::Writer& w, const Header& h) {
  w.value<std::int32_t>(static_cast<std::int32_t>(h.sec));
  w.value<std::uint32_t>(h.nsec);
  w.string(h.frame_id);
}

void write_vector3(cdr::Writer& w, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) w.value<double>(v[i]);
}

void write_pose(cdr::Writer& w, const Pose& p) {
  write_vector3(w, p.translation());
  const Eigen::Quaterniond q(p.linear());
  for (double v : {q.x(), q.y(), q.z(), q.w()}) w.value<double>(v);
}

void write_zeros(cdr::Writer& w, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) w.value<double>(0.0);
}

void check_time(const Header& h) {
  if (h.sec < std::numeric_limits<std::int32_t>::min() || h.sec > std::numeric_limits<std::int32_t>::max()) {
    throw Error("a ROS 2 message needs a time in int32 seconds (before 2^31 s), not " + std::to_string(h.sec) + " s");
  }
}

// The three pose messages: a header; Odometry's child_frame_id; the pose, PoseStamped's as is, the others' as
// PoseWithCovariance (a float64[36] after it); Odometry's twist with its covariance (42 float64) last.
struct PoseLayout {
  const char* type;
  bool child, covariance, twist;
  const char *position, *orientation;
};
constexpr PoseLayout kOdometryLayout{kOdometry, true, true, true, "pose.pose.position", "pose.pose.orientation"};
constexpr PoseLayout kPoseStampedLayout{kPoseStamped, false, false, false, "pose.position", "pose.orientation"};
constexpr PoseLayout kPoseWithCovarianceLayout{kPoseWithCovarianceStamped, false, true, false, "pose.pose.position",
                                               "pose.pose.orientation"};

PoseMessage read_pose_message(const std::uint8_t* data, std::size_t size, const std::string& what,
                              const PoseLayout& l) {
  cdr::Reader r(data, size, what);
  PoseMessage p;
  p.header = read_header(r);
  if (l.child) p.child_frame_id = r.string("child_frame_id");
  p.pose = read_pose(r, l.position, l.orientation);
  if (l.covariance) skip_doubles(r, 36, "pose.covariance");
  if (l.twist) skip_doubles(r, 6 + 36, "twist");
  r.expect_end(l.type);
  return p;
}

std::vector<std::uint8_t> write_pose_message(const PoseMessage& m, bool big_endian, const PoseLayout& l) {
  check_time(m.header);
  cdr::Writer w(!big_endian);
  write_header(w, m.header);
  if (l.child) w.string(m.child_frame_id);
  write_pose(w, m.pose);
  if (l.covariance) write_zeros(w, 36);
  if (l.twist) write_zeros(w, 6 + 36);
  return w.take();
}

}  // namespace

Header decode_header(const std::uint8_t* data, std::size_t size, const std::string& what) {
  cdr::Reader r(data, size, what);
  return read_header(r);
}

PointCloud2Message decode_pointcloud2_message(const std::uint8_t* data, std::size_t size, const std::string& what) {
  cdr::Reader r(data, size, what);
  PointCloud2Message m;
  m.header = read_header(r);
  m.layout.height = r.value<std::uint32_t>("height");
  m.layout.width = r.value<std::uint32_t>("width");
  // A field: name (4 + bytes), offset 4, datatype 1, count 4 (after alignment).
  const std::uint32_t fields = r.sequence_length("fields", 13);
  m.layout.fields.reserve(fields);
  for (std::uint32_t i = 0; i < fields; ++i) {
    PointField f;
    f.name = r.string("fields.name");
    f.offset = r.value<std::uint32_t>("fields.offset");
    f.datatype = r.value<std::uint8_t>("fields.datatype");
    f.count = r.value<std::uint32_t>("fields.count");
    m.layout.fields.push_back(std::move(f));
  }
  m.layout.is_bigendian = r.boolean("is_bigendian");
  m.layout.point_step = r.value<std::uint32_t>("point_step");
  m.layout.row_step = r.value<std::uint32_t>("row_step");
  const std::uint32_t data_size = r.sequence_length("data", 1);
  m.data_offset = r.skip(data_size, "data");
  m.data_size = data_size;
  m.layout.is_dense = r.boolean("is_dense");
  r.expect_end(kPointCloud2);
  return m;
}

std::vector<TransformStamped> decode_tf_message(const std::uint8_t* data, std::size_t size, const std::string& what) {
  cdr::Reader r(data, size, what);
  // header, child_frame_id (4 + bytes), 7 doubles.
  const std::uint32_t n = r.sequence_length("transforms", kHeaderMinBytes + 4 + 56);
  std::vector<TransformStamped> out;
  out.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    TransformStamped t;
    t.header = read_header(r);
    t.child_frame_id = r.string("child_frame_id");
    t.transform = read_pose(r, "transform.translation", "transform.rotation");
    out.push_back(std::move(t));
  }
  r.expect_end(kTfMessage);
  return out;
}

PoseMessage decode_odometry(const std::uint8_t* data, std::size_t size, const std::string& what) {
  return read_pose_message(data, size, what, kOdometryLayout);
}

PoseMessage decode_pose_stamped(const std::uint8_t* data, std::size_t size, const std::string& what) {
  return read_pose_message(data, size, what, kPoseStampedLayout);
}

PoseMessage decode_pose_with_covariance_stamped(const std::uint8_t* data, std::size_t size, const std::string& what) {
  return read_pose_message(data, size, what, kPoseWithCovarianceLayout);
}

Imu decode_imu(const std::uint8_t* data, std::size_t size, const std::string& what) {
  cdr::Reader r(data, size, what);
  Imu m;
  m.header = read_header(r);
  skip_doubles(r, 4 + 9, "orientation");  // often all zero (unknown): not used
  m.angular_velocity = read_vector3(r, "angular_velocity");
  skip_doubles(r, 9, "angular_velocity_covariance");
  m.linear_acceleration = read_vector3(r, "linear_acceleration");
  skip_doubles(r, 9, "linear_acceleration_covariance");
  r.expect_end(kImu);
  return m;
}

std::vector<std::uint8_t> encode_pointcloud2_message(const Header& header, const PointCloud2Layout& layout,
                                                     const std::vector<std::uint8_t>& data, bool big_endian) {
  check_time(header);
  cdr::Writer w(!big_endian);
  write_header(w, header);
  w.value<std::uint32_t>(layout.height);
  w.value<std::uint32_t>(layout.width);
  w.sequence_length(layout.fields.size());
  for (const PointField& f : layout.fields) {
    w.string(f.name);
    w.value<std::uint32_t>(f.offset);
    w.value<std::uint8_t>(f.datatype);
    w.value<std::uint32_t>(f.count);
  }
  w.boolean(layout.is_bigendian);
  w.value<std::uint32_t>(layout.point_step);
  w.value<std::uint32_t>(layout.row_step);
  w.sequence_length(data.size());
  w.raw(data.data(), data.size());
  w.boolean(layout.is_dense);
  return w.take();
}

std::vector<std::uint8_t> encode_tf_message(const std::vector<TransformStamped>& transforms, bool big_endian) {
  cdr::Writer w(!big_endian);
  w.sequence_length(transforms.size());
  for (const TransformStamped& t : transforms) {
    check_time(t.header);
    write_header(w, t.header);
    w.string(t.child_frame_id);
    write_pose(w, t.transform);
  }
  return w.take();
}

std::vector<std::uint8_t> encode_odometry(const PoseMessage& odometry, bool big_endian) {
  return write_pose_message(odometry, big_endian, kOdometryLayout);
}

std::vector<std::uint8_t> encode_pose_stamped(const PoseMessage& pose, bool big_endian) {
  return write_pose_message(pose, big_endian, kPoseStampedLayout);
}

std::vector<std::uint8_t> encode_pose_with_covariance_stamped(const PoseMessage& pose, bool big_endian) {
  return write_pose_message(pose, big_endian, kPoseWithCovarianceLayout);
}

std::vector<std::uint8_t> encode_imu(const Imu& imu, bool big_endian) {
  check_time(imu.header);
  cdr::Writer w(!big_endian);
  write_header(w, imu.header);
  for (double v : {0.0, 0.0, 0.0, 1.0}) w.value<double>(v);  // orientation: identity, marked unknown below
  w.value<double>(-1.0);
  write_zeros(w, 8);
  write_vector3(w, imu.angular_velocity);
  write_zeros(w, 9);
  write_vector3(w, imu.linear_acceleration);
  write_zeros(w, 9);
  return w.take();
}

}  // namespace tsdf_mcl::ros2
