#include "tsdf_mcl/io/cloud_io.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <string>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/io/pcd_format.hpp"
#include "ply_format.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

bool VectorPointSource::next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) {
  const std::size_t n = std::min(max, points_.size() - at_);
  chunk.assign(points_.begin() + static_cast<std::ptrdiff_t>(at_),
               points_.begin() + static_cast<std::ptrdiff_t>(at_ + n));
  at_ += n;
  return n > 0;
}

namespace {

// A regular file read through a buffer, by lines, tokens or bytes.
class BufferedFile {
 public:
  explicit BufferedFile(const fs::path& file) : name_(file.string()) {
    size_ = input_file_size(file, "cloud", ~std::uint64_t{0});
    // O_NONBLOCK: should the file have been swapped for a FIFO since the check, open() must not wait for a writer.
    fd_ = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw Error("cannot open cloud " + name_ + ": " + std::strerror(errno));
    buffer_.resize(kBuffer);
  }
  ~BufferedFile() { ::close(fd_); }
  BufferedFile(const BufferedFile&) = delete;
  BufferedFile& operator=(const BufferedFile&) = delete;

  const std::string& name() const { return name_; }
  std::uint64_t remaining() const { return size_ - consumed_; }

  // The next line without its '\n'; false at the end of the file. Lines longer than max_length are an error.
  bool line(std::string& out, std::size_t max_length) {
    out.clear();
    if (!fill()) return false;
    while (true) {
      const char* begin = buffer_.data() + at_;
      const char* nl = static_cast<const char*>(std::memchr(begin, '\n', end_ - at_));
      const std::size_t n = nl ? static_cast<std::size_t>(nl - begin) : end_ - at_;
      if (out.size() + n > max_length)
        throw Error(name_ + ": a line longer than " + std::to_string(max_length) + " bytes (corrupt)");
      out.append(begin, n);
      advance(n + (nl ? 1 : 0));
      if (nl || !fill()) return true;
    }
  }

  // The next run of non-space characters; empty at the end of the file.
  std::string_view token() {
    token_.clear();
    while (fill() && std::isspace(static_cast<unsigned char>(buffer_[at_]))) advance(1);
    while (fill() && !std::isspace(static_cast<unsigned char>(buffer_[at_]))) {
      if (token_.size() >= 256) throw Error(name_ + ": a value longer than 256 characters (corrupt)");
      token_.push_back(buffer_[at_]);
      advance(1);
    }
    return token_;
  }

  // Exactly n bytes, or an Error saying the data is truncated.
  void read(unsigned char* out, std::size_t n, const char* what) {
    while (n > 0) {
      if (!fill()) throw Error(name_ + ": " + what + " truncated (the file ends early)");
      const std::size_t k = std::min(n, end_ - at_);
      std::memcpy(out, buffer_.data() + at_, k);
      advance(k);
      out += k;
      n -= k;
    }
  }

 private:
  static constexpr std::size_t kBuffer = std::size_t{1} << 20;
  void advance(std::size_t n) {
    at_ += n;
    consumed_ += n;
  }
  bool fill() {
    if (at_ < end_) return true;
    at_ = end_ = 0;
    while (true) {
      const ssize_t n = ::read(fd_, buffer_.data(), buffer_.size());
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw Error("cannot read cloud " + name_ + ": " + std::strerror(errno));
      end_ = static_cast<std::size_t>(n);
      return n > 0;
    }
  }

  std::string name_;
  int fd_ = -1;
  std::uint64_t size_ = 0, consumed_ = 0;
  std::vector<char> buffer_;
  std::size_t at_ = 0, end_ = 0;
  std::string token_;
};

bool parse_double(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

std::string lower_extension(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

constexpr std::size_t kMaxHeaderLine = std::size_t{1} << 16;
// Binary reads are done in pieces of about this many bytes, whatever the record size.
constexpr std::size_t kChunkBytes = std::size_t{8} << 20;

}  // namespace

class CloudReader::Impl {
 public:
  virtual ~Impl() = default;
  virtual std::uint64_t size() const = 0;
  virtual bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) = 0;
  virtual const char* format() const = 0;
};

namespace {

class PcdReader : public CloudReader::Impl {
 public:
  PcdReader(const fs::path& file, std::uint64_t max_buffer) : in_(file) {
    h_ = io::parse_pcd_header([this](std::string& line) { return in_.line(line, kMaxHeaderLine); }, in_.name(),
                              limits::kMaxCloudPoints);
    if (h_.data == "ascii") {
      format_ = "PCD ascii";
      values_.resize(h_.columns);
      return;
    }
    const std::uint64_t needed = io::checked_mul(h_.points, h_.stride, in_.name());
    if (h_.data == "binary") {
      format_ = "PCD binary";
      if (needed > in_.remaining()) {
        throw Error(in_.name() + ": PCD data truncated: " + std::to_string(h_.points) + " points of " +
                    std::to_string(h_.stride) + " bytes need " + std::to_string(needed) + " bytes, the file has " +
                    std::to_string(in_.remaining()));
      }
      return;
    }
    format_ = "PCD binary_compressed";
    unsigned char sizes[8];
    in_.read(sizes, 8, "PCD binary_compressed sizes");
    const std::uint32_t packed = io::load<std::uint32_t>(sizes, true),
                        unpacked = io::load<std::uint32_t>(sizes + 4, true);
    if (unpacked != needed) {
      throw Error(in_.name() + ": PCD binary_compressed payload of " + std::to_string(unpacked) + " bytes, but " +
                  std::to_string(h_.points) + " points of " + std::to_string(h_.stride) + " bytes need " +
                  std::to_string(needed));
    }
    if (packed > in_.remaining()) throw Error(in_.name() + ": PCD binary_compressed data truncated");
    io::check_lzf_sizes(packed, unpacked, max_buffer > packed ? max_buffer - packed : 0, in_.name());
    std::vector<unsigned char> compressed(packed);
    in_.read(compressed.data(), packed, "PCD binary_compressed data");
    unpacked_.resize(unpacked);
    io::lzf_decompress(compressed.data(), packed, unpacked_.data(), unpacked, in_.name());
  }

  std::uint64_t size() const override { return h_.points; }
  const char* format() const override { return format_; }

  bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) override {
    chunk.clear();
    const std::uint64_t left = h_.points - done_;
    if (left == 0) return false;
    const int xyz[3] = {h_.x, h_.y, h_.z};
    if (h_.data == "ascii") {
      std::string line;
      while (chunk.size() < max && done_ < h_.points) {
        if (!in_.line(line, std::size_t{64} << 20)) {
          throw Error(in_.name() + ": PCD has fewer points than its header says (" + std::to_string(done_) + " of " +
                      std::to_string(h_.points) + ")");
        }
        const char* p = line.data();
        const char* const end = line.data() + line.size();
        for (double& v : values_) {
          while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
          const auto [next_p, ec] = std::from_chars(p, end, v);
          if (ec != std::errc()) throw Error(in_.name() + ": PCD row " + std::to_string(done_) + " has too few values");
          p = next_p;
        }
        chunk.emplace_back(static_cast<float>(values_[h_.column[static_cast<std::size_t>(h_.x)]]),
                           static_cast<float>(values_[h_.column[static_cast<std::size_t>(h_.y)]]),
                           static_cast<float>(values_[h_.column[static_cast<std::size_t>(h_.z)]]));
        ++done_;
      }
      return true;
    }
    if (h_.data == "binary") {
      const std::size_t n = static_cast<std::size_t>(
          std::min<std::uint64_t>({left, max, std::max<std::size_t>(1, kChunkBytes / h_.stride)}));
      records_.resize(n * h_.stride);
      in_.read(records_.data(), records_.size(), "PCD data");
      chunk.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        const unsigned char* r = records_.data() + i * h_.stride;
        for (int a = 0; a < 3; ++a) {
          chunk[i][a] =
              static_cast<float>(io::pcd_coordinate(h_, xyz[a], r + h_.offset[static_cast<std::size_t>(xyz[a])]));
        }
      }
      done_ += n;
      return true;
    }
    // binary_compressed: each field's values for all points, one field after the other.
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, max));
    chunk.resize(n);
    for (int a = 0; a < 3; ++a) {
      const auto f = static_cast<std::size_t>(xyz[a]);
      const std::size_t element = h_.sizes[f] * h_.counts[f];
      const unsigned char* base = unpacked_.data() + h_.offset[f] * h_.points;
      for (std::size_t i = 0; i < n; ++i) {
        chunk[i][a] = static_cast<float>(io::pcd_coordinate(h_, xyz[a], base + (done_ + i) * element));
      }
    }
    done_ += n;
    if (done_ == h_.points) std::vector<unsigned char>().swap(unpacked_);
    return true;
  }

 private:
  BufferedFile in_;
  io::PcdHeader h_;
  const char* format_ = "PCD";
  std::uint64_t done_ = 0;
  std::vector<double> values_;
  std::vector<unsigned char> records_, unpacked_;
};

class PlyReader : public CloudReader::Impl {
 public:
  explicit PlyReader(const fs::path& file) : in_(file) {
    const io::PlyHeader header = io::parse_ply_header(
        [this](std::string& line) { return in_.line(line, kMaxHeaderLine); }, in_.name(), limits::kMaxCloudPoints);
    format_ = header.format;
    // Every row takes at least a byte per value in binary files and two (a digit and a separator) in ascii ones:
    // counts the rest of the file cannot hold are corrupt, and must not size loops.
    std::uint64_t min_bytes = 0;
    const bool ascii = format_ == io::PlyFormat::kAscii;
    bool found = false;
    for (const io::PlyElement& e : header.elements) {
      std::uint64_t row = 0;
      for (const io::PlyProperty& p : e.properties) row += ascii ? 2 : io::ply_size(p.is_list ? p.count_type : p.type);
      if (row == 0 && e.count > 0) throw Error(in_.name() + ": PLY element " + e.name + " has rows but no properties");
      min_bytes = io::checked_add(min_bytes, io::checked_mul(row, e.count, in_.name()), in_.name());
      if (e.name == "vertex") {
        vertex_ = e;
        found = true;
        break;  // what follows the vertices is never read
      }
      before_.push_back(e);
    }
    if (!found) throw Error(in_.name() + ": PLY has no vertex element");
    for (std::size_t k = 0; k < vertex_.properties.size(); ++k) {
      const io::PlyProperty& p = vertex_.properties[k];
      for (int a = 0; a < 3; ++a) {
        if (!p.is_list && p.name == std::string(1, static_cast<char>('x' + a))) xyz_[a] = static_cast<int>(k);
      }
      fixed_ = fixed_ && !p.is_list;
      record_ += io::ply_size(p.type);
    }
    if (xyz_[0] < 0 || xyz_[1] < 0 || xyz_[2] < 0) throw Error(in_.name() + ": PLY vertices lack x, y or z");
    if (min_bytes > in_.remaining()) {
      throw Error(in_.name() + ": PLY header announces at least " + std::to_string(min_bytes) +
                  " bytes of elements, the file has " + std::to_string(in_.remaining()) +
                  " after the header (truncated or corrupt)");
    }
    // Elements before the vertices (rare) are read and dropped.
    for (const io::PlyElement& e : before_) {
      for (std::size_t row = 0; row < e.count; ++row) read_row(e, row, nullptr);
    }
  }

  std::uint64_t size() const override { return vertex_.count; }
  const char* format() const override {
    return format_ == io::PlyFormat::kAscii          ? "PLY ascii"
           : format_ == io::PlyFormat::kBinaryLittle ? "PLY binary little endian"
                                                     : "PLY binary big endian";
  }

  bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) override {
    chunk.clear();
    const std::uint64_t left = vertex_.count - done_;
    if (left == 0) return false;
    if (fixed_ && format_ != io::PlyFormat::kAscii) {
      const std::size_t n = static_cast<std::size_t>(
          std::min<std::uint64_t>({left, max, std::max<std::size_t>(1, kChunkBytes / record_)}));
      records_.resize(n * record_);
      in_.read(records_.data(), records_.size(), "PLY vertex data");
      std::size_t offset[3] = {0, 0, 0};
      for (int a = 0; a < 3; ++a) {
        for (int k = 0; k < xyz_[a]; ++k)
          offset[a] += io::ply_size(vertex_.properties[static_cast<std::size_t>(k)].type);
      }
      chunk.resize(n);
      const bool le = format_ == io::PlyFormat::kBinaryLittle;
      for (std::size_t i = 0; i < n; ++i) {
        for (int a = 0; a < 3; ++a) {
          chunk[i][a] = static_cast<float>(io::ply_value(vertex_.properties[static_cast<std::size_t>(xyz_[a])].type,
                                                         records_.data() + i * record_ + offset[a], le));
        }
      }
      done_ += n;
      return true;
    }
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, max));
    chunk.resize(n);
    for (std::size_t i = 0; i < n; ++i) read_row(vertex_, done_ + i, &chunk[i]);
    done_ += n;
    return true;
  }

 private:
  double value(io::PlyType type, const io::PlyElement& e, std::size_t row) {
    if (format_ == io::PlyFormat::kAscii) {
      const std::string_view token = in_.token();
      double v = 0.0;
      if (token.empty())
        throw Error(in_.name() + ": PLY data ends early (truncated) in element " + e.name + " " + std::to_string(row));
      if (!parse_double(token, v)) {
        throw Error(in_.name() + ": malformed PLY value '" + std::string(token) + "' in element " + e.name + " " +
                    std::to_string(row));
      }
      return v;
    }
    unsigned char bytes[8];
    in_.read(bytes, io::ply_size(type), "PLY data");
    return io::ply_value(type, bytes, format_ == io::PlyFormat::kBinaryLittle);
  }

  // Reads one row of `e`; the vertex's x y z go to `point` if given.
  void read_row(const io::PlyElement& e, std::size_t row, Eigen::Vector3f* point) {
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const io::PlyProperty& p = e.properties[k];
      if (!p.is_list) {
        const double v = value(p.type, e, row);
        for (int a = 0; a < 3; ++a) {
          if (point && xyz_[a] == static_cast<int>(k)) (*point)[a] = static_cast<float>(v);
        }
        continue;
      }
      const double n = value(p.count_type, e, row);
      if (!(n >= 0) || n != static_cast<double>(static_cast<long long>(n)) || n > 1e6) {
        throw Error(in_.name() + ": bad PLY list length in element " + e.name + " " + std::to_string(row));
      }
      for (long long i = 0; i < static_cast<long long>(n); ++i) value(p.type, e, row);
    }
  }

  BufferedFile in_;
  io::PlyFormat format_ = io::PlyFormat::kAscii;
  io::PlyElement vertex_;
  std::vector<io::PlyElement> before_;
  int xyz_[3] = {-1, -1, -1};
  bool fixed_ = true;
  std::size_t record_ = 0;
  std::uint64_t done_ = 0;
  std::vector<unsigned char> records_;
};

}  // namespace

CloudReader::CloudReader(const fs::path& file, std::uint64_t max_buffer_bytes) {
  const std::string ext = lower_extension(file);
  if (ext == ".pcd") {
    impl_ = std::make_unique<PcdReader>(file, max_buffer_bytes);
  } else if (ext == ".ply") {
    impl_ = std::make_unique<PlyReader>(file);
  } else {
    throw Error("cloud " + file.string() + ": unknown extension '" + ext + "' (expected .pcd or .ply)");
  }
}

CloudReader::~CloudReader() = default;
std::uint64_t CloudReader::size_hint() const { return impl_->size(); }
bool CloudReader::next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) { return impl_->next(chunk, max); }
const char* CloudReader::format() const { return impl_->format(); }

std::vector<Eigen::Vector3f> read_cloud(const fs::path& file) {
  CloudReader reader(file);
  std::vector<Eigen::Vector3f> points, chunk;
  while (reader.next(chunk, std::size_t{1} << 20)) points.insert(points.end(), chunk.begin(), chunk.end());
  return points;
}

void write_pcd(const fs::path& file, const std::vector<Eigen::Vector3f>& points) {
  const std::string n = std::to_string(points.size());
  std::string out =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
      "COUNT 1 1 1\nWIDTH " +
      n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n";
  out.reserve(out.size() + 12 * points.size());
  for (const Eigen::Vector3f& p : points) {
    for (int a = 0; a < 3; ++a) io::append_le(out, p[a]);
  }
  write_file_atomically(file, out, "cloud");
}

std::uint64_t write_dataset_cloud(const Dataset& dataset, const std::vector<std::size_t>& scans, float min_range,
                                  float max_range, const fs::path& file) {
  if (!dataset.has_poses())
    throw Error("dataset " + dataset.dir().string() + " has no poses.txt (needed to place the scans)");
  // Calls f(world point) for every kept point of every selected scan.
  const auto each_point = [&](auto&& f) {
    for (std::size_t i : scans) {
      const PointCloud cloud = dataset.load_scan(i);
      const Eigen::Matrix3f r = dataset.pose(i).linear().cast<float>();
      const Eigen::Vector3f t = dataset.pose(i).translation().cast<float>();
      for (const Eigen::Vector3f& p : cloud.points) {
        const float range = p.norm();
        if (range >= min_range && range <= max_range) f(Eigen::Vector3f(r * p + t));
      }
    }
  };
  std::uint64_t count = 0;
  each_point([&](const Eigen::Vector3f&) { ++count; });
  if (count == 0) throw Error("no scan point lies within the range limits");
  write_file_atomically(
      file,
      [&](const fs::path& temporary) {
        std::FILE* out = std::fopen(temporary.c_str(), "wb");
        if (!out) throw Error("cannot create " + temporary.string() + ": " + std::strerror(errno));
        const std::string n = std::to_string(count);
        const std::string header =
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n"
            "TYPE F F F\nCOUNT 1 1 1\nWIDTH " +
            n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n";
        bool ok = std::fwrite(header.data(), 1, header.size(), out) == header.size();
        std::string buffer;
        each_point([&](const Eigen::Vector3f& p) {
          for (int a = 0; a < 3; ++a) io::append_le(buffer, p[a]);
          if (buffer.size() >= (std::size_t{1} << 20)) {
            ok = ok && std::fwrite(buffer.data(), 1, buffer.size(), out) == buffer.size();
            buffer.clear();
          }
        });
        ok = ok && std::fwrite(buffer.data(), 1, buffer.size(), out) == buffer.size();
        ok = std::fclose(out) == 0 && ok;
        if (!ok) throw Error("cannot write " + temporary.string() + ": " + std::strerror(errno));
      },
      "cloud");
  return count;
}

std::vector<Eigen::Vector3f> read_trajectory_positions(const fs::path& path) {
  std::vector<Eigen::Vector3f> out;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    const Dataset dataset = Dataset::open(path);
    if (!dataset.has_poses()) throw Error("dataset " + path.string() + " has no poses.txt (the trajectory)");
    for (const Pose& p : dataset.poses()) out.push_back(p.translation().cast<float>());
  } else {
    for (const StampedPose& p : read_tum(path)) out.push_back(p.pose.translation().cast<float>());
  }
  if (out.empty()) throw Error("trajectory " + path.string() + " has no poses");
  return out;
}

}  // namespace tsdf_mcl
