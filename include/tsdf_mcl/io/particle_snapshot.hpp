#pragma once
// Particle snapshots: the particle set at one moment of a localization run, written by `tsdf-mcl localize` and drawn
// by `tsdf-mcl render --particles`.
//
// File layout, all little-endian:
//   0  char[8]  magic "TSDFPART"
//   8  uint32   format version (1)
//  12  uint32   particle count N
//  16  N records of 8 float32: x, y, z, qw, qx, qy, qz, weight (world_T_sensor; weights sum to 1)
// The file size must be exactly 16 + 32 N bytes.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <vector>

namespace tsdf_mcl {

struct ParticleSnapshot {
  struct Particle {
    Eigen::Vector3f position = Eigen::Vector3f::Zero();
    Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
    float weight = 0.0f;
  };
  std::vector<Particle> particles;
};

// Writes the snapshot with its weights normalized to sum 1, replacing the file only once it is complete. Throws
// Error naming the file for non-finite values, negative weights, weights summing to zero or a failed write.
void write_particle_snapshot(const std::filesystem::path& file, const ParticleSnapshot& snapshot);
// Throws Error naming the file if it is missing, not a snapshot, of another version, truncated or has trailing
// bytes, or holds non-finite values, a zero quaternion or a negative weight. Orientations are returned normalized,
// weights as stored.
ParticleSnapshot read_particle_snapshot(const std::filesystem::path& file);

}  // namespace tsdf_mcl
