#include "tsdf_mcl/io/dataset.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/io/pcd_format.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

std::vector<std::size_t> ScanSelection::indices(std::size_t scan_count) const {
  if (stride == 0) throw Error("--stride must be at least 1");
  std::vector<std::size_t> out;
  // Stepping by comparing what is left: i + stride may wrap for a huge --stride.
  for (std::size_t i = start; i < scan_count; i += stride) {
    if (count != 0 && out.size() == count) break;
    out.push_back(i);
    if (stride >= scan_count - i) break;
  }
  return out;
}

namespace {

std::string at_line(const fs::path& file, std::size_t line) {
  return file.string() + ":" + std::to_string(line) + ": ";
}

// Calls parse(line, line number) for every line of a dataset's text file that is not blank.
template <typename Parse>
void for_each_line(const fs::path& file, const std::string& what, Parse&& parse) {
  std::istringstream in(read_input_file(file, what, limits::kMaxTextFileBytes));
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    parse(line, line_no);
  }
}

// True if nothing but white space follows in `ss`.
bool at_end(std::istringstream& ss) {
  ss >> std::ws;
  return ss.eof();
}

std::vector<double> read_times(const fs::path& file) {
  std::vector<double> times;
  for_each_line(file, "timestamps", [&](const std::string& line, std::size_t line_no) {
    std::istringstream ss(line);
    double t;
    if (!(ss >> t) || !std::isfinite(t) || !at_end(ss)) {
      throw Error(at_line(file, line_no) + "expected one timestamp, got '" + line + "'");
    }
    times.push_back(t);
  });
  return times;
}

// A scan's decompressed PCD payload: 2^24 points of x y z intensity and then some.
constexpr std::uint64_t kMaxUnpackedScanBytes = std::uint64_t{1} << 30;

// PCD v0.7 (ascii, binary, binary_compressed). Every header field is checked before any memory is sized by it, and
// the payload the header implies against the file's real size.
PointCloud read_pcd(const fs::path& file) {
  const std::string bytes = read_input_file(file, "scan", limits::kMaxScanPoints * 256);
  const std::string name = file.string();
  std::istringstream in(bytes);
  const io::PcdHeader h = io::parse_pcd_header(
      [&in](std::string& line) { return static_cast<bool>(std::getline(in, line)); }, name, limits::kMaxScanPoints);
  const std::size_t body = in.eof() ? bytes.size() : static_cast<std::size_t>(in.tellg());
  const std::size_t available = bytes.size() - body;
  PointCloud cloud;
  const int ii = h.intensity;
  if (h.data == "ascii") {
    // Each value takes at least two bytes (a digit and a separator): the rows the file can hold bound the reserve.
    cloud.points.reserve(std::min<std::size_t>(h.points, available / (2 * h.columns) + 1));
    std::vector<double> values(h.columns);
    std::string line;
    while (cloud.points.size() < h.points && std::getline(in, line)) {
      const char* p = line.data();
      const char* const end = line.data() + line.size();
      for (auto& v : values) {
        while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
        const auto [next, ec] = std::from_chars(p, end, v);
        if (ec != std::errc())
          throw Error(name + ": PCD row " + std::to_string(cloud.points.size()) + " has too few values");
        p = next;
      }
      cloud.points.emplace_back(values[h.column[static_cast<std::size_t>(h.x)]],
                                values[h.column[static_cast<std::size_t>(h.y)]],
                                values[h.column[static_cast<std::size_t>(h.z)]]);
      if (ii >= 0) cloud.intensity.push_back(static_cast<float>(values[h.column[static_cast<std::size_t>(ii)]]));
    }
  } else {
    const std::uint64_t needed = io::checked_mul(h.points, h.stride, name);
    const auto* base = reinterpret_cast<const unsigned char*>(bytes.data()) + body;
    // binary: records of `stride` bytes; binary_compressed: LZF of the fields one after the other (all x, all y, ...).
    std::string unpacked;
    std::size_t record = h.stride;
    std::vector<std::size_t> field_base = h.offset;
    if (h.data == "binary_compressed") {
      if (available < 8) throw Error(name + ": PCD binary_compressed data truncated (no sizes)");
      const std::uint32_t packed = io::load<std::uint32_t>(base, true), size = io::load<std::uint32_t>(base + 4, true);
      if (size != needed) {
        throw Error(name + ": PCD binary_compressed payload of " + std::to_string(size) + " bytes, but " +
                    std::to_string(h.points) + " points of " + std::to_string(h.stride) + " bytes need " +
                    std::to_string(needed));
      }
      if (packed > available - 8) throw Error(name + ": PCD binary_compressed data truncated");
      io::check_lzf_sizes(packed, size, kMaxUnpackedScanBytes, name);
      unpacked.resize(size);
      io::lzf_decompress(base + 8, packed, reinterpret_cast<unsigned char*>(unpacked.data()), size, name);
      base = reinterpret_cast<const unsigned char*>(unpacked.data());
      for (std::size_t f = 0; f < h.fields.size(); ++f) field_base[f] = h.offset[f] * h.points;
      record = 0;
    } else if (needed > available) {
      throw Error(name + ": PCD data truncated: " + std::to_string(h.points) + " points of " +
                  std::to_string(h.stride) + " bytes need " + std::to_string(needed) + " bytes, the file has " +
                  std::to_string(available));
    }
    cloud.points.reserve(h.points);
    const int idx[3] = {h.x, h.y, h.z};
    for (std::size_t p = 0; p < h.points; ++p) {
      double v[3];
      for (int k = 0; k < 3; ++k) {
        const auto f = static_cast<std::size_t>(idx[k]);
        const std::size_t at = record ? p * record + field_base[f] : field_base[f] + p * h.sizes[f] * h.counts[f];
        v[k] = io::pcd_coordinate(h, idx[k], base + at);
      }
      cloud.points.emplace_back(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
      if (ii >= 0) {
        const auto f = static_cast<std::size_t>(ii);
        cloud.intensity.push_back(
            io::load<float>(base + (record ? p * record + field_base[f] : field_base[f] + p * h.counts[f] * 4), true));
      }
    }
  }
  if (cloud.points.size() != h.points) throw Error(name + ": PCD has fewer points than its header says");
  return cloud;
}

std::string kitti_line(const Pose& pose) {
  const auto v = kitti_of(pose);
  std::string line;
  char number[32];
  for (int k = 0; k < 12; ++k) {
    std::snprintf(number, sizeof(number), k == 11 ? "%.9f\n" : "%.9f ", v[static_cast<std::size_t>(k)]);
    line += number;
  }
  return line;
}

}  // namespace

PointCloud read_kitti_bin(const fs::path& file) {
  const std::string bytes = read_input_file(file, "scan", limits::kMaxScanPoints * 16);
  if (bytes.size() % 16 != 0) {
    throw Error(file.string() + ": size " + std::to_string(bytes.size()) +
                " is not a multiple of 16 (float32 x y z intensity)");
  }
  const auto* raw = reinterpret_cast<const unsigned char*>(bytes.data());
  PointCloud cloud;
  const std::size_t n = bytes.size() / 16;
  cloud.points.resize(n);
  cloud.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* point = raw + 16 * i;
    cloud.points[i] = Eigen::Vector3f(io::load<float>(point, true), io::load<float>(point + 4, true),
                                      io::load<float>(point + 8, true));
    cloud.intensity[i] = io::load<float>(point + 12, true);
  }
  return cloud;
}

void write_kitti_bin(const fs::path& file, const PointCloud& cloud) {
  std::string bytes;
  bytes.reserve(cloud.size() * 16);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) io::append_le(bytes, cloud.points[i][a]);
    io::append_le(bytes, cloud.intensity.empty() ? 0.0f : cloud.intensity[i]);
  }
  write_file_atomically(file, bytes, "scan");
}

std::vector<Pose> read_kitti_poses(const fs::path& file) {
  std::vector<Pose> poses;
  for_each_line(file, "poses", [&](const std::string& line, std::size_t line_no) {
    std::istringstream ss(line);
    std::array<double, 12> v{};
    for (auto& x : v) {
      if (!(ss >> x) || !std::isfinite(x)) {
        throw Error(at_line(file, line_no) + "expected 12 finite numbers (3x4 row-major pose)");
      }
    }
    if (!at_end(ss)) throw Error(at_line(file, line_no) + "more than 12 numbers on a pose line");
    Eigen::Matrix3d r;
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) r(row, col) = v[static_cast<std::size_t>(row * 4 + col)];
    if (!is_rotation_matrix(r)) {
      throw Error(at_line(file, line_no) + "not a rotation: R^T R differs from I by " +
                  std::to_string((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff()) +
                  ", det R = " + std::to_string(r.determinant()) + " (needs orthonormal rows, det +1, within " +
                  std::to_string(kRotationTolerance) + ")");
    }
    poses.push_back(pose_from_kitti(v));
  });
  return poses;
}

void write_kitti_poses(const fs::path& file, const std::vector<Pose>& poses) {
  std::string text;
  for (const Pose& p : poses) text += kitti_line(p);
  write_file_atomically(file, text, "poses");
}

std::vector<StampedPose> read_tum(const fs::path& file) {
  std::vector<StampedPose> out;
  for_each_line(file, "trajectory", [&](const std::string& line, std::size_t line_no) {
    if (line[line.find_first_not_of(" \t")] == '#') return;
    std::istringstream ss(line);
    double v[8];
    for (double& x : v) {
      if (!(ss >> x) || !std::isfinite(x)) throw Error(at_line(file, line_no) + "expected 't x y z qx qy qz qw'");
    }
    if (!at_end(ss)) throw Error(at_line(file, line_no) + "more than 8 numbers on a TUM line ('t x y z qx qy qz qw')");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-6) throw Error(at_line(file, line_no) + "zero quaternion");
    StampedPose sp;
    sp.time = v[0];
    sp.pose.linear() = q.normalized().toRotationMatrix();
    sp.pose.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    out.push_back(sp);
  });
  return out;
}

void write_tum(const fs::path& file, const std::vector<StampedPose>& trajectory) {
  std::string text;
  char line[256];
  for (const auto& sp : trajectory) {
    const Eigen::Quaterniond q(sp.pose.linear());
    const Eigen::Vector3d t = sp.pose.translation();
    std::snprintf(line, sizeof(line), "%.9f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", sp.time, t.x(), t.y(), t.z(), q.x(),
                  q.y(), q.z(), q.w());
    text += line;
  }
  write_file_atomically(file, text, "trajectory");
}

Dataset Dataset::open(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error("dataset " + dir.string() + " is not a directory");
  Dataset ds;
  ds.dir_ = dir;
  if (!fs::exists(dir / "times.txt", ec)) throw Error("dataset " + dir.string() + " has no times.txt");
  if (!fs::is_directory(dir / "scans", ec)) throw Error("dataset " + dir.string() + " has no scans/ folder");
  ds.times_ = read_times(dir / "times.txt");
  for (fs::directory_iterator it(dir / "scans", ec), end; !ec && it != end; it.increment(ec)) {
    const auto ext = it->path().extension();
    std::error_code type_error;
    if (it->is_regular_file(type_error) && (ext == ".bin" || ext == ".pcd" || ext == ".ply")) {
      ds.scan_files_.push_back(it->path());
    }
  }
  if (ec) throw Error("cannot list " + (dir / "scans").string() + ": " + ec.message());
  std::sort(ds.scan_files_.begin(), ds.scan_files_.end());
  if (ds.scan_files_.empty()) throw Error("dataset " + dir.string() + ": scans/ holds no .bin/.pcd/.ply files");
  if (ds.scan_files_.size() != ds.times_.size()) {
    throw Error("dataset " + dir.string() + ": " + std::to_string(ds.scan_files_.size()) + " scans but " +
                std::to_string(ds.times_.size()) + " lines in times.txt");
  }
  for (std::size_t i = 1; i < ds.times_.size(); ++i) {
    if (!(ds.times_[i] > ds.times_[i - 1])) {
      throw Error((dir / "times.txt").string() + ":" + std::to_string(i + 1) + ": timestamps must increase");
    }
  }
  for (const auto& [name, target] : {std::pair{"poses.txt", &ds.poses_}, std::pair{"odom.txt", &ds.odometry_}}) {
    if (!fs::exists(dir / name, ec)) continue;
    *target = read_kitti_poses(dir / name);
    if (target->size() != ds.times_.size()) {
      throw Error("dataset " + dir.string() + ": " + std::to_string(target->size()) + " lines in " + name + " but " +
                  std::to_string(ds.times_.size()) + " in times.txt");
    }
  }
  return ds;
}

void Dataset::set_poses(std::vector<Pose> poses) {
  if (poses.size() != times_.size()) {
    throw Error("set_poses: " + std::to_string(poses.size()) + " poses for " + std::to_string(times_.size()) +
                " scans");
  }
  poses_ = std::move(poses);
}

std::optional<Pose> pose_at(const std::vector<StampedPose>& trajectory, double time) {
  constexpr double kSlack = 1e-6;
  if (trajectory.empty() || time < trajectory.front().time - kSlack || time > trajectory.back().time + kSlack) {
    return std::nullopt;
  }
  const auto hi = std::lower_bound(trajectory.begin(), trajectory.end(), time,
                                   [](const StampedPose& p, double t) { return p.time < t; });
  if (hi == trajectory.end()) return trajectory.back().pose;
  if (hi == trajectory.begin() || hi->time - time <= kSlack) return hi->pose;
  const auto lo = std::prev(hi);
  if (time - lo->time <= kSlack) return lo->pose;
  return interpolate_pose(lo->pose, hi->pose, (time - lo->time) / (hi->time - lo->time));
}

fs::path Dataset::scan_path(std::size_t i) const {
  if (source_) {
    (void)times_.at(i);  // the same out_of_range as a folder's for a bad index
    return source_->name(i);
  }
  return scan_files_.at(i);
}

std::string Dataset::missing_odometry() const {
  return source_ ? missing_odometry_ : "dataset " + dir_.string() + " has no odom.txt";
}

std::string Dataset::missing_poses() const {
  return source_ ? missing_poses_ : "dataset " + dir_.string() + " has no poses.txt";
}

std::vector<ImuSample> Dataset::imu() const {
  if (source_) return imu_;
  std::error_code ec;
  const fs::path file = dir_ / "imu.txt";
  return fs::exists(file, ec) ? read_imu(file) : std::vector<ImuSample>{};
}

PointCloud Dataset::load_scan(std::size_t i, std::size_t* dropped_non_finite) const {
  if (source_) {
    (void)times_.at(i);  // the same out_of_range as a folder's for a bad index
    return source_->load(i, dropped_non_finite);
  }
  const fs::path& file = scan_files_.at(i);
  PointCloud raw;
  if (file.extension() == ".bin") {
    raw = read_kitti_bin(file);
  } else if (file.extension() == ".pcd") {
    raw = read_pcd(file);
  } else {
    throw Error(file.string() + ": .ply scans are not supported yet; convert to .bin");
  }
  if (raw.empty()) throw Error(file.string() + ": empty scan file");
  PointCloud out;
  out.points.reserve(raw.size());
  std::size_t dropped = 0;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (!raw.points[k].allFinite()) {
      ++dropped;
      continue;
    }
    out.points.push_back(raw.points[k]);
    if (!raw.intensity.empty()) out.intensity.push_back(raw.intensity[k]);
  }
  if (out.empty())
    throw Error(file.string() + ": no finite points (" + std::to_string(dropped) + " NaN/Inf points dropped)");
  if (dropped_non_finite) *dropped_non_finite = dropped;
  return out;
}

void Dataset::check_scans_not_empty(const std::vector<std::size_t>& scans) const {
  if (source_) return;  // a bag's clouds are only read by load_scan
  for (std::size_t i : scans) {
    std::error_code ec;
    if (fs::file_size(scan_files_.at(i), ec) == 0 && !ec) throw Error(scan_files_.at(i).string() + ": empty scan file");
  }
}

DatasetWriter::DatasetWriter(const fs::path& dir) : dir_(dir) {
  std::error_code ec;
  fs::create_directories(dir / "scans", ec);
  if (ec) throw Error("cannot create " + (dir / "scans").string() + ": " + ec.message());
}

void DatasetWriter::add(double time, const PointCloud& scan, const std::optional<Pose>& pose,
                        const std::optional<Pose>& odometry) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.bin", times_.size());
  write_kitti_bin(dir_ / "scans" / name, scan);
  times_.push_back(time);
  if (pose) poses_.push_back(*pose);
  if (odometry) odometry_.push_back(*odometry);
}

void DatasetWriter::close() {
  if (closed_) return;
  closed_ = true;
  std::string text;
  char line[64];
  for (double t : times_) {
    std::snprintf(line, sizeof(line), "%.9f\n", t);
    text += line;
  }
  write_file_atomically(dir_ / "times.txt", text, "timestamps");
  if (!poses_.empty()) write_kitti_poses(dir_ / "poses.txt", poses_);
  if (!odometry_.empty()) write_kitti_poses(dir_ / "odom.txt", odometry_);
}

DatasetWriter::~DatasetWriter() {
  try {
    close();
  } catch (...) {
    // Destructors must not throw; callers that care call close() themselves.
  }
}

}  // namespace tsdf_mcl
