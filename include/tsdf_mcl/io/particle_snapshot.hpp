#pragma once
// Particle snapshots: the particle set at one moment of a localization run, written by `tsdf-mcl localize` and drawn
// by `tsdf-mcl render --particles`.
//
// File layout, all little-endian:
//   0  char[8]  magic "TSDFPART"
//   8  uint32   format version (2; version 1 files, without hypotheses, are read too)
//  12  uint32   particle count N
//  16  uint32   hypothesis count H (version 2)
//  20  N records of 8 float32: x, y, z, qw, qx, qy, qz, weight (world_T_sensor; weights sum to 1)
//      H records of the same layout: the belief's hypotheses as the filter ranked them, best first, each at its
//      mean pose with its share of the belief as the weight
// The file size must be exactly 20 + 32 (N + H) bytes (version 1: 16 + 32 N).
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
  // The belief's modes (pose_estimate.hpp) best first, weight = share of the belief: carried so that a viewer
  // draws what the filter found without running the filter's estimator itself.
  std::vector<Particle> hypotheses;
};

// Writes the snapshot with its weights normalized to sum 1, replacing the file only once it is complete. Throws
// Error naming the file for non-finite values, negative weights, weights summing to zero or a failed write.
void write_particle_snapshot(const std::filesystem::path& file, const ParticleSnapshot& snapshot);
// Throws Error naming the file if it is missing, not a snapshot, of another version, truncated or has trailing
// bytes, or holds non-finite values, a zero quaternion or a negative weight. Orientations are returned normalized,
// weights as stored.
ParticleSnapshot read_particle_snapshot(const std::filesystem::path& file);

}  // namespace tsdf_mcl
