#include "tsdf_mcl/io/particle_snapshot.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

constexpr char kMagic[8] = {'T', 'S', 'D', 'F', 'P', 'A', 'R', 'T'};
constexpr std::uint32_t kFormatVersion = 2;
constexpr std::size_t kHeaderBytes = 20;
constexpr std::size_t kHeaderBytesVersion1 = 16;  // no hypothesis count
constexpr std::size_t kRecordFloats = 8;
constexpr std::size_t kRecordBytes = kRecordFloats * sizeof(float);

// Checks a pose-and-weight record (`what`: "particle 3", "hypothesis 0") for writing; throws Error naming it.
void check_record(const ParticleSnapshot::Particle& p, const std::string& name, const std::string& what) {
  if (!p.position.allFinite() || !p.orientation.coeffs().allFinite() || !std::isfinite(p.weight)) {
    throw Error(name + ": " + what + " has a non-finite value");
  }
  if (p.weight < 0.0f) throw Error(name + ": " + what + " has a negative weight");
}

void append_record(std::string& bytes, const ParticleSnapshot::Particle& p, float weight) {
  const Eigen::Quaternionf q = p.orientation.normalized();
  for (const float v : {p.position.x(), p.position.y(), p.position.z(), q.w(), q.x(), q.y(), q.z(), weight}) {
    io::append_le(bytes, v);
  }
}

// Reads record `i` at `at`; throws Error naming the file and `what` for non-finite values, a zero quaternion or a
// negative weight.
ParticleSnapshot::Particle read_record(const unsigned char* at, const std::string& name, const std::string& what) {
  float v[kRecordFloats];
  for (std::size_t k = 0; k < kRecordFloats; ++k) {
    v[k] = io::load<float>(at + k * sizeof(float), true);
    if (!std::isfinite(v[k])) throw Error(name + ": " + what + " has a non-finite value");
  }
  ParticleSnapshot::Particle p;
  p.position = {v[0], v[1], v[2]};
  p.orientation = Eigen::Quaternionf(v[3], v[4], v[5], v[6]);
  if (!(p.orientation.norm() > 1e-6f)) throw Error(name + ": " + what + " has a zero orientation quaternion");
  p.orientation.normalize();
  if (v[7] < 0.0f) throw Error(name + ": " + what + " has a negative weight");
  p.weight = v[7];
  return p;
}

}  // namespace

void write_particle_snapshot(const fs::path& file, const ParticleSnapshot& snapshot) {
  const std::string name = "particle snapshot " + file.string();
  if (snapshot.particles.size() > 0xFFFFFFFFu) throw Error(name + ": more than 2^32 - 1 particles");
  if (snapshot.hypotheses.size() > 0xFFFFFFFFu) throw Error(name + ": more than 2^32 - 1 hypotheses");
  double sum = 0.0;
  for (std::size_t i = 0; i < snapshot.particles.size(); ++i) {
    check_record(snapshot.particles[i], name, "particle " + std::to_string(i));
    sum += snapshot.particles[i].weight;
  }
  if (!snapshot.particles.empty() && !(sum > 0.0)) throw Error(name + ": the particle weights sum to zero");
  for (std::size_t i = 0; i < snapshot.hypotheses.size(); ++i) {
    check_record(snapshot.hypotheses[i], name, "hypothesis " + std::to_string(i));
  }

  std::string bytes(kMagic, sizeof(kMagic));
  io::append_le(bytes, kFormatVersion);
  io::append_le(bytes, static_cast<std::uint32_t>(snapshot.particles.size()));
  io::append_le(bytes, static_cast<std::uint32_t>(snapshot.hypotheses.size()));
  bytes.reserve(kHeaderBytes + (snapshot.particles.size() + snapshot.hypotheses.size()) * kRecordBytes);
  for (const auto& p : snapshot.particles) append_record(bytes, p, static_cast<float>(p.weight / sum));
  for (const auto& h : snapshot.hypotheses) append_record(bytes, h, h.weight);

  // Written beside the target and renamed over it: a viewer polling the file never sees half a snapshot.
  write_file_atomically(file, bytes, "particle snapshot");
}

ParticleSnapshot read_particle_snapshot(const fs::path& file) {
  const std::string name = "particle snapshot " + file.string();
  const std::string bytes =
      read_input_file(file, "particle snapshot", kHeaderBytes + (std::uint64_t{1} << 33) * kRecordBytes);
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());

  if (bytes.size() < sizeof(kMagic) || std::memcmp(data, kMagic, sizeof(kMagic)) != 0) {
    throw Error(name + ": not a particle snapshot (no TSDFPART header)");
  }
  if (bytes.size() < kHeaderBytesVersion1) {
    throw Error(name + ": truncated: " + std::to_string(bytes.size()) + " bytes, the header alone has " +
                std::to_string(kHeaderBytesVersion1));
  }
  const auto version = io::load<std::uint32_t>(data + 8, true);
  if (version != 1 && version != kFormatVersion) {
    throw Error(name + ": unsupported version " + std::to_string(version) + " (this build reads versions 1 and " +
                std::to_string(kFormatVersion) + ")");
  }
  const std::size_t header = version == 1 ? kHeaderBytesVersion1 : kHeaderBytes;
  if (bytes.size() < header) {
    throw Error(name + ": truncated: " + std::to_string(bytes.size()) + " bytes, the header alone has " +
                std::to_string(header));
  }
  const auto count = io::load<std::uint32_t>(data + 12, true);
  const std::uint32_t hypotheses = version == 1 ? 0 : io::load<std::uint32_t>(data + 16, true);
  const std::uint64_t expected = header + (std::uint64_t{count} + hypotheses) * kRecordBytes;
  const std::string announced =
      std::to_string(count) + " particles" + (version == 1 ? "" : " and " + std::to_string(hypotheses) + " hypotheses");
  if (bytes.size() < expected) {
    throw Error(name + ": truncated: " + announced + " need " + std::to_string(expected) + " bytes, the file has " +
                std::to_string(bytes.size()));
  }
  if (bytes.size() > expected) {
    throw Error(name + ": " + std::to_string(bytes.size() - expected) + " bytes after the " + announced +
                " its header announces (corrupt header or trailing data)");
  }

  ParticleSnapshot snapshot;
  snapshot.particles.resize(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    snapshot.particles[i] =
        read_record(data + header + std::size_t{i} * kRecordBytes, name, "particle " + std::to_string(i));
  }
  snapshot.hypotheses.resize(hypotheses);
  for (std::uint32_t i = 0; i < hypotheses; ++i) {
    snapshot.hypotheses[i] =
        read_record(data + header + (std::size_t{count} + i) * kRecordBytes, name, "hypothesis " + std::to_string(i));
  }
  return snapshot;
}

}  // namespace tsdf_mcl
