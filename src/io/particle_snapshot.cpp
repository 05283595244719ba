#include "tsdf_mcl/io/particle_snapshot.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/io/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/input_file.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

constexpr char kMagic[8] = {'T', 'S', 'D', 'F', 'P', 'A', 'R', 'T'};
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::size_t kHeaderBytes = 16;
constexpr std::size_t kRecordFloats = 8;
constexpr std::size_t kRecordBytes = kRecordFloats * sizeof(float);

}  // namespace

void write_particle_snapshot(const fs::path& file, const ParticleSnapshot& snapshot) {
  const std::string name = "particle snapshot " + file.string();
  if (snapshot.particles.size() > 0xFFFFFFFFu) throw Error(name + ": more than 2^32 - 1 particles");
  double sum = 0.0;
  for (std::size_t i = 0; i < snapshot.particles.size(); ++i) {
    const auto& p = snapshot.particles[i];
    if (!p.position.allFinite() || !p.orientation.coeffs().allFinite() || !std::isfinite(p.weight)) {
      throw Error(name + ": particle " + std::to_string(i) + " has a non-finite value");
    }
    if (p.weight < 0.0f) throw Error(name + ": particle " + std::to_string(i) + " has a negative weight");
    sum += p.weight;
  }
  if (!snapshot.particles.empty() && !(sum > 0.0)) throw Error(name + ": the particle weights sum to zero");

  std::string bytes(kMagic, sizeof(kMagic));
  io::append_le(bytes, kFormatVersion);
  io::append_le(bytes, static_cast<std::uint32_t>(snapshot.particles.size()));
  bytes.reserve(kHeaderBytes + snapshot.particles.size() * kRecordBytes);
  for (const auto& p : snapshot.particles) {
    const Eigen::Quaternionf q = p.orientation.normalized();
    for (const float v : {p.position.x(), p.position.y(), p.position.z(), q.w(), q.x(), q.y(), q.z(),
                          static_cast<float>(p.weight / sum)}) {
      io::append_le(bytes, v);
    }
  }

  // Written beside the target and renamed over it: a viewer polling the file never sees half a snapshot.
  write_file_atomically(file, bytes, "particle snapshot");
}

ParticleSnapshot read_particle_snapshot(const fs::path& file) {
  const std::string name = "particle snapshot " + file.string();
  const std::string bytes =
      read_input_file(file, "particle snapshot", kHeaderBytes + (std::uint64_t{1} << 32) * kRecordBytes);
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());

  if (bytes.size() < sizeof(kMagic) || std::memcmp(data, kMagic, sizeof(kMagic)) != 0) {
    throw Error(name + ": not a particle snapshot (no TSDFPART header)");
  }
  if (bytes.size() < kHeaderBytes) {
    throw Error(name + ": truncated: " + std::to_string(bytes.size()) + " bytes, the header alone has " +
                std::to_string(kHeaderBytes));
  }
  const auto version = io::load<std::uint32_t>(data + 8, true);
  if (version != kFormatVersion) {
    throw Error(name + ": unsupported version " + std::to_string(version) + " (this build reads version " +
                std::to_string(kFormatVersion) + ")");
  }
  const auto count = io::load<std::uint32_t>(data + 12, true);
  const std::uint64_t expected = kHeaderBytes + std::uint64_t{count} * kRecordBytes;
  if (bytes.size() < expected) {
    throw Error(name + ": truncated: " + std::to_string(count) + " particles need " + std::to_string(expected) +
                " bytes, the file has " + std::to_string(bytes.size()));
  }
  if (bytes.size() > expected) {
    throw Error(name + ": " + std::to_string(bytes.size() - expected) + " bytes after the " + std::to_string(count) +
                " particles its header announces (corrupt header or trailing data)");
  }

  ParticleSnapshot snapshot;
  snapshot.particles.resize(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    float v[kRecordFloats];
    for (std::size_t k = 0; k < kRecordFloats; ++k) {
      v[k] = io::load<float>(data + kHeaderBytes + std::size_t{i} * kRecordBytes + k * sizeof(float), true);
      if (!std::isfinite(v[k])) throw Error(name + ": particle " + std::to_string(i) + " has a non-finite value");
    }
    auto& p = snapshot.particles[i];
    p.position = {v[0], v[1], v[2]};
    p.orientation = Eigen::Quaternionf(v[3], v[4], v[5], v[6]);
    if (!(p.orientation.norm() > 1e-6f)) {
      throw Error(name + ": particle " + std::to_string(i) + " has a zero orientation quaternion");
    }
    p.orientation.normalize();
    if (v[7] < 0.0f) throw Error(name + ": particle " + std::to_string(i) + " has a negative weight");
    p.weight = v[7];
  }
  return snapshot;
}

}  // namespace tsdf_mcl
