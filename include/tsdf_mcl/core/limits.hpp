#pragma once
// The documented limits of tsdf-mcl (README "Limits"): every input is checked against them before memory is
// allocated or arithmetic is done on it, so that a corrupt or hostile file ends in one clear error instead of a
// crash, a hang or gigabytes of memory. Limits that a real user may need to raise have an option (named here).
#include <cstddef>
#include <cstdint>

namespace tsdf_mcl::limits {

// ----------------------------------------------------------------------------------------------------- maps
// Voxel size range (m): below a millimetre float positions no longer resolve voxels; beyond 10 m a TSDF is
// meaningless for LiDAR localization.
inline constexpr float kMinVoxelSize = 0.001f;
inline constexpr float kMaxVoxelSize = 10.0f;
// Truncation at most this many voxels: every scan point walks 2 * truncation / voxel voxels.
inline constexpr float kMaxTruncationVoxels = 1000.0f;
// Every voxel index of a map lies within +-2^24: exactly representable as float, and voxel arithmetic
// (index * 8, index + offsets) cannot overflow int32.
inline constexpr std::int32_t kMaxAbsVoxelIndex = 1 << 24;
// Coarse index cells (the map's bounding box in blocks of 8^3 voxels).
inline constexpr std::uint64_t kMaxCoarseCells = std::uint64_t{1} << 28;
// Working memory of build-map (the map plus the builder's own buffers), in MiB; --max_memory raises it.
inline constexpr std::size_t kDefaultBuildMemoryMiB = 2048;

// ---------------------------------------------------------------------------------------------------- files
// Mesh files (STL, PLY, OBJ) are read whole.
inline constexpr std::uint64_t kMaxMeshFileBytes = std::uint64_t{4} << 30;
// Mesh elements (vertices, faces, triangles after fan splitting).
inline constexpr std::uint64_t kMaxMeshElements = std::uint64_t{1} << 28;
// Points of one scan (.bin, .pcd): 2^24 is 16.7 million, ~80 sweeps of a 128-beam LiDAR.
inline constexpr std::uint64_t kMaxScanPoints = std::uint64_t{1} << 24;
// Points of a map cloud (build-map --cloud, .pcd/.ply): streamed, so memory follows the occupied voxels, not this.
inline constexpr std::uint64_t kMaxCloudPoints = std::uint64_t{1} << 34;
// Text files of a dataset (times.txt, poses.txt, odom.txt) and TUM trajectories.
inline constexpr std::uint64_t kMaxTextFileBytes = std::uint64_t{1} << 30;
// Bags (Dataset::open_bag) are read message by message, never whole: a bag may be as large as the disk, one
// serialized message at most 1 GiB (a 2^24-point scan of 64-byte points).
inline constexpr std::uint64_t kMaxBagFileBytes = std::uint64_t{1} << 50;
inline constexpr std::uint64_t kMaxBagMessageBytes = std::uint64_t{1} << 30;
// rosbag2 MCAP files are read chunk by chunk: one chunk's records at most 1 GiB + 1 MiB (a largest message and the
// records around it; writers close a chunk at a few MiB).
inline constexpr std::uint64_t kMaxMcapChunkBytes = kMaxBagMessageBytes + (std::uint64_t{1} << 20);
// A rosbag2 folder's metadata.yaml (a few KB per topic and storage file).
inline constexpr std::uint64_t kMaxBagMetadataBytes = std::uint64_t{16} << 20;
// localize's report.json, read back by evaluate (about 2 KB per scan).
inline constexpr std::uint64_t kMaxReportFileBytes = std::uint64_t{256} << 20;
// Parameter files (--config) and the values they may hold after YAML aliases are followed.
inline constexpr std::uint64_t kMaxConfigFileBytes = std::uint64_t{1} << 20;
inline constexpr std::size_t kMaxConfigValues = 10000;

// ------------------------------------------------------------------------------------------ filter options
inline constexpr std::size_t kMaxParticles = 10'000'000;  // --particles, --min_particles, --max_particles
inline constexpr std::size_t kMaxBeams = 1 << 20;         // --max_beams
inline constexpr std::size_t kMaxThreads = 256;           // --cpu_threads

}  // namespace tsdf_mcl::limits
