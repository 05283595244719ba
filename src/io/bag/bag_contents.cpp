// BagContents through the pipe from open_bag's child process: little-endian numbers, counted texts and lists.
#include "bag_contents.hpp"

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/little_endian.hpp"

namespace tsdf_mcl::bag_io {
namespace {

class Encoder {
 public:
  void u64(std::uint64_t v) { io::append_le(bytes_, v); }
  void f64(double v) { io::append_le(bytes_, v); }
  void text(const std::string& s) {
    u64(s.size());
    bytes_ += s;
  }
  void pose(const Pose& p) {
    for (double v : kitti_of(p)) f64(v);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class Decoder {
 public:
  explicit Decoder(const std::string& bytes) : bytes_(bytes) {}
  std::uint64_t u64() { return take<std::uint64_t>(); }
  double f64() { return take<double>(); }
  std::string text() {
    const std::uint64_t n = count(1);
    std::string s = bytes_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  // The 12 numbers as they were: the pipe is transport, not a reader of pose files (pose_from_kitti would
  // orthonormalize them, and the dataset would differ by rounding from the same bag read without a child process).
  Pose pose() {
    Pose p = Pose::Identity();
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 4; ++col) p.matrix()(row, col) = f64();
    }
    return p;
  }
  // A count of items of at least `item_bytes` each, checked against what is left.
  std::uint64_t count(std::uint64_t item_bytes) {
    const std::uint64_t n = u64();
    if (n > (bytes_.size() - pos_) / item_bytes) throw Error("bag reader: its child process answered garbage");
    return n;
  }

 private:
  template <typename T>
  T take() {
    if (bytes_.size() - pos_ < sizeof(T)) throw Error("bag reader: its child process answered garbage");
    const T v = io::load<T>(reinterpret_cast<const unsigned char*>(bytes_.data()) + pos_, true);
    pos_ += sizeof(T);
    return v;
  }
  const std::string& bytes_;
  std::size_t pos_ = 0;
};

}  // namespace

std::string encode(const BagContents& c) {
  Encoder e;
  e.text(c.points_topic);
  e.u64(c.scan_ordinals.size());
  for (std::uint64_t k : c.scan_ordinals) e.u64(k);
  e.u64(c.times.size());
  for (double t : c.times) e.f64(t);
  for (const std::vector<Pose>* poses : {&c.odometry, &c.poses}) {
    e.u64(poses->size());
    for (const Pose& p : *poses) e.pose(p);
  }
  e.u64(c.imu.size());
  for (const ImuSample& s : c.imu) {
    e.f64(s.time);
    for (int a = 0; a < 3; ++a) e.f64(s.acceleration[a]);
  }
  e.text(c.summary);
  e.text(c.missing_odometry);
  e.text(c.missing_poses);
  return e.bytes();
}

BagContents decode(const std::string& bytes) {
  Decoder d(bytes);
  BagContents c;
  c.points_topic = d.text();
  for (std::uint64_t n = d.count(8), k = 0; k < n; ++k) c.scan_ordinals.push_back(d.u64());
  for (std::uint64_t n = d.count(8), k = 0; k < n; ++k) c.times.push_back(d.f64());
  for (std::vector<Pose>* poses : {&c.odometry, &c.poses}) {
    for (std::uint64_t n = d.count(96), k = 0; k < n; ++k) poses->push_back(d.pose());
  }
  for (std::uint64_t n = d.count(32), k = 0; k < n; ++k) {
    ImuSample s;
    s.time = d.f64();
    for (int a = 0; a < 3; ++a) s.acceleration[a] = d.f64();
    c.imu.push_back(s);
  }
  c.summary = d.text();
  c.missing_odometry = d.text();
  c.missing_poses = d.text();
  return c;
}

}  // namespace tsdf_mcl::bag_io
