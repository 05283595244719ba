#pragma once
// Point clouds of whole maps (the PCD and PLY files SLAM systems write), read in chunks: a cloud larger than memory
// streams through a consumer that keeps only what it needs (build_map_from_cloud keeps one point per voxel).
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl {

// A source of points, read once from the start, in chunks.
class PointSource {
 public:
  virtual ~PointSource() = default;
  // Points the source announces (for progress); 0 if unknown.
  virtual std::uint64_t size_hint() const = 0;
  // Replaces `chunk` with the next at most `max` points (non-finite ones included: the consumer counts them);
  // false, with `chunk` empty, when none are left. Throws Error on corrupt or truncated data.
  virtual bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) = 0;
};

// The points of a vector, as a PointSource.
class VectorPointSource : public PointSource {
 public:
  explicit VectorPointSource(const std::vector<Eigen::Vector3f>& points) : points_(points) {}
  std::uint64_t size_hint() const override { return points_.size(); }
  bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) override;

 private:
  const std::vector<Eigen::Vector3f>& points_;
  std::size_t at_ = 0;
};

// PCD (ascii, binary, binary_compressed; x y z float32 or float64, any other fields) or PLY (ascii, binary
// little/big endian; the vertex element's x y z of any numeric type; faces and other elements are ignored), by
// extension. The header is read and checked on construction (limits::kMaxCloudPoints, the payload it implies against
// the file's size). Only binary_compressed PCD cannot stream: its decompressed payload is held whole, at most
// `max_buffer_bytes`.
class CloudReader : public PointSource {
 public:
  explicit CloudReader(const std::filesystem::path& file, std::uint64_t max_buffer_bytes = std::uint64_t{1} << 30);
  ~CloudReader() override;
  CloudReader(const CloudReader&) = delete;
  CloudReader& operator=(const CloudReader&) = delete;

  std::uint64_t size_hint() const override;
  bool next(std::vector<Eigen::Vector3f>& chunk, std::size_t max) override;
  const char* format() const;  // e.g. "PCD binary", "PLY ascii"

  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Reads a whole cloud file (tests, small clouds).
std::vector<Eigen::Vector3f> read_cloud(const std::filesystem::path& file);
// Writes a binary PCD (x y z float32), atomically.
void write_pcd(const std::filesystem::path& file, const std::vector<Eigen::Vector3f>& points);
// Writes the selected scans of a dataset, placed at its poses and range-filtered, as one world-frame binary PCD (a
// SLAM system's map cloud), atomically, reading each scan twice rather than holding them. Returns the point count.
std::uint64_t write_dataset_cloud(const Dataset& dataset, const std::vector<std::size_t>& scans, float min_range,
                                  float max_range, const std::filesystem::path& file);
// Sensor positions of a mapping run: a TUM trajectory file, or a dataset folder (its poses.txt).
std::vector<Eigen::Vector3f> read_trajectory_positions(const std::filesystem::path& path);

}  // namespace tsdf_mcl
