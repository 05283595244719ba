#include "tsdf_mcl/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

std::vector<std::size_t> ScanSelection::indices(std::size_t scan_count) const {
  if (stride == 0) throw Error("--stride must be at least 1");
  std::vector<std::size_t> out;
  for (std::size_t i = start; i < scan_count; i += stride) {
    if (count != 0 && out.size() == count) break;
    out.push_back(i);
  }
  return out;
}

namespace {

std::vector<double> read_times(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("cannot open " + file.string());
  std::vector<double> times;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    double t;
    if (!(ss >> t) || !std::isfinite(t)) {
      throw Error(file.string() + ":" + std::to_string(line_no) + ": expected a timestamp, got '" + line + "'");
    }
    times.push_back(t);
  }
  return times;
}

PointCloud read_pcd(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("cannot open " + file.string());
  std::vector<std::string> fields;
  std::vector<int> sizes;
  std::vector<char> types;
  std::vector<int> counts;
  std::size_t points = 0;
  std::string data;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "FIELDS") {
      for (std::string f; ss >> f;) fields.push_back(f);
    } else if (key == "SIZE") {
      for (int s; ss >> s;) sizes.push_back(s);
    } else if (key == "TYPE") {
      for (char t; ss >> t;) types.push_back(t);
    } else if (key == "COUNT") {
      for (int c; ss >> c;) counts.push_back(c);
    } else if (key == "POINTS") {
      ss >> points;
    } else if (key == "DATA") {
      ss >> data;
      break;
    }
  }
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size() ||
      counts.size() != fields.size()) {
    throw Error(file.string() + ": malformed PCD header");
  }
  int ix = -1, iy = -1, iz = -1, ii = -1;
  std::vector<std::size_t> offset(fields.size());
  std::size_t stride = 0;
  std::size_t columns = 0;
  std::vector<std::size_t> column(fields.size());
  for (std::size_t f = 0; f < fields.size(); ++f) {
    offset[f] = stride;
    column[f] = columns;
    stride += static_cast<std::size_t>(sizes[f] * counts[f]);
    columns += static_cast<std::size_t>(counts[f]);
    if (fields[f] == "x") ix = static_cast<int>(f);
    if (fields[f] == "y") iy = static_cast<int>(f);
    if (fields[f] == "z") iz = static_cast<int>(f);
    if (fields[f] == "intensity") ii = static_cast<int>(f);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw Error(file.string() + ": PCD has no x y z fields");
  for (int f : {ix, iy, iz, ii}) {
    if (f >= 0 && (types[f] != 'F' || sizes[f] != 4)) throw Error(file.string() + ": PCD x/y/z must be float32");
  }
  PointCloud cloud;
  cloud.points.reserve(points);
  if (data == "ascii") {
    std::vector<double> values(columns);
    while (cloud.points.size() < points && std::getline(in, line)) {
      std::istringstream ss(line);
      for (auto& v : values) {
        if (!(ss >> v)) throw Error(file.string() + ": PCD row has too few values");
      }
      cloud.points.emplace_back(values[column[ix]], values[column[iy]], values[column[iz]]);
      if (ii >= 0) cloud.intensity.push_back(static_cast<float>(values[column[ii]]));
    }
  } else if (data == "binary") {
    std::vector<char> buffer(points * stride);
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    if (static_cast<std::size_t>(in.gcount()) != buffer.size()) throw Error(file.string() + ": PCD data truncated");
    for (std::size_t p = 0; p < points; ++p) {
      float v[4] = {0, 0, 0, 0};
      const int idx[4] = {ix, iy, iz, ii};
      for (int k = 0; k < 4; ++k) {
        if (idx[k] >= 0) std::memcpy(&v[k], buffer.data() + p * stride + offset[idx[k]], 4);
      }
      cloud.points.emplace_back(v[0], v[1], v[2]);
      if (ii >= 0) cloud.intensity.push_back(v[3]);
    }
  } else {
    throw Error(file.string() + ": PCD DATA '" + data + "' not supported (ascii or binary)");
  }
  if (cloud.points.size() != points) throw Error(file.string() + ": PCD has fewer points than its header says");
  return cloud;
}

}  // namespace

PointCloud read_kitti_bin(const fs::path& file) {
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw Error("cannot open scan " + file.string());
  const auto bytes = static_cast<std::size_t>(in.tellg());
  if (bytes % 16 != 0) {
    throw Error(file.string() + ": size " + std::to_string(bytes) + " is not a multiple of 16 (float32 x y z intensity)");
  }
  in.seekg(0);
  std::vector<float> raw(bytes / 4);
  in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(bytes));
  if (!in) throw Error("cannot read scan " + file.string());
  PointCloud cloud;
  const std::size_t n = bytes / 16;
  cloud.points.resize(n);
  cloud.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud.points[i] = Eigen::Vector3f(raw[4 * i], raw[4 * i + 1], raw[4 * i + 2]);
    cloud.intensity[i] = raw[4 * i + 3];
  }
  return cloud;
}

void write_kitti_bin(const fs::path& file, const PointCloud& cloud) {
  std::vector<float> raw(cloud.size() * 4);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    raw[4 * i] = cloud.points[i].x();
    raw[4 * i + 1] = cloud.points[i].y();
    raw[4 * i + 2] = cloud.points[i].z();
    raw[4 * i + 3] = cloud.intensity.empty() ? 0.0f : cloud.intensity[i];
  }
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(raw.data()), static_cast<std::streamsize>(raw.size() * 4));
  if (!out) throw Error("cannot write " + file.string());
}

std::vector<Pose> read_kitti_poses(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("cannot open " + file.string());
  std::vector<Pose> poses;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    std::array<double, 12> v{};
    for (auto& x : v) {
      if (!(ss >> x) || !std::isfinite(x)) {
        throw Error(file.string() + ":" + std::to_string(line_no) + ": expected 12 finite numbers (3x4 row-major pose)");
      }
    }
    if (double extra; ss >> extra) {
      throw Error(file.string() + ":" + std::to_string(line_no) + ": more than 12 numbers on a pose line");
    }
    poses.push_back(pose_from_kitti(v));
  }
  return poses;
}

void write_kitti_poses(const fs::path& file, const std::vector<Pose>& poses) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  if (!f) throw Error("cannot write " + file.string());
  for (const Pose& p : poses) {
    const auto v = kitti_of(p);
    for (int k = 0; k < 12; ++k) std::fprintf(f, k == 11 ? "%.9f\n" : "%.9f ", v[k]);
  }
  if (std::fclose(f) != 0) throw Error("cannot write " + file.string());
}

std::vector<StampedPose> read_tum(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("cannot open " + file.string());
  std::vector<StampedPose> out;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    double v[8];
    for (double& x : v) {
      if (!(ss >> x) || !std::isfinite(x)) {
        throw Error(file.string() + ":" + std::to_string(line_no) + ": expected 't x y z qx qy qz qw'");
      }
    }
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-6) throw Error(file.string() + ":" + std::to_string(line_no) + ": zero quaternion");
    StampedPose sp;
    sp.time = v[0];
    sp.pose.linear() = q.normalized().toRotationMatrix();
    sp.pose.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    out.push_back(sp);
  }
  return out;
}

void write_tum(const fs::path& file, const std::vector<StampedPose>& trajectory) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  if (!f) throw Error("cannot write " + file.string());
  for (const auto& sp : trajectory) {
    const Eigen::Quaterniond q(sp.pose.linear());
    const Eigen::Vector3d t = sp.pose.translation();
    std::fprintf(f, "%.9f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", sp.time, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(),
                 q.w());
  }
  if (std::fclose(f) != 0) throw Error("cannot write " + file.string());
}

Dataset Dataset::open(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw Error("dataset " + dir.string() + " is not a directory");
  Dataset ds;
  ds.dir_ = dir;
  if (!fs::exists(dir / "times.txt")) throw Error("dataset " + dir.string() + " has no times.txt");
  if (!fs::is_directory(dir / "scans")) throw Error("dataset " + dir.string() + " has no scans/ folder");
  ds.times_ = read_times(dir / "times.txt");
  for (const auto& entry : fs::directory_iterator(dir / "scans")) {
    const auto ext = entry.path().extension();
    if (entry.is_regular_file() && (ext == ".bin" || ext == ".pcd" || ext == ".ply")) {
      ds.scan_files_.push_back(entry.path());
    }
  }
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
    if (!fs::exists(dir / name)) continue;
    *target = read_kitti_poses(dir / name);
    if (target->size() != ds.times_.size()) {
      throw Error("dataset " + dir.string() + ": " + std::to_string(target->size()) + " lines in " + name +
                  " but " + std::to_string(ds.times_.size()) + " in times.txt");
    }
  }
  return ds;
}

fs::path Dataset::scan_path(std::size_t i) const { return scan_files_.at(i); }

PointCloud Dataset::load_scan(std::size_t i, std::size_t* dropped_non_finite) const {
  const fs::path& file = scan_files_.at(i);
  PointCloud raw;
  if (file.extension() == ".bin") {
    raw = read_kitti_bin(file);
  } else if (file.extension() == ".pcd") {
    raw = read_pcd(file);
  } else {
    throw Error(file.string() + ": .ply scans are not supported yet; convert to .bin");
  }
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
  if (dropped_non_finite) *dropped_non_finite = dropped;
  return out;
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
  std::FILE* f = std::fopen((dir_ / "times.txt").c_str(), "w");
  if (!f) throw Error("cannot write " + (dir_ / "times.txt").string());
  for (double t : times_) std::fprintf(f, "%.9f\n", t);
  std::fclose(f);
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
