#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"

using Eigen::Quaternionf;
using Eigen::Vector3f;
using tsdf_mcl::Error;
using tsdf_mcl::ParticleSnapshot;
using tsdf_mcl::test::read_bytes;
using tsdf_mcl::test::TempDir;
using tsdf_mcl::test::write_bytes;

namespace {

ParticleSnapshot sample_snapshot() {
  ParticleSnapshot s;
  s.particles.push_back({Vector3f(1.0f, 2.0f, 3.0f), Quaternionf(Eigen::AngleAxisf(0.3f, Vector3f::UnitZ())), 2.0f});
  s.particles.push_back({Vector3f(-4.5f, 0.25f, 0.0f), Quaternionf(2.0f, 0.0f, 0.0f, 0.0f), 6.0f});  // not unit
  s.particles.push_back(
      {Vector3f(0.0f, 0.0f, -1.0f), Quaternionf(Eigen::AngleAxisf(-2.0f, Vector3f(1, 1, 0).normalized())), 0.0f});
  s.hypotheses.push_back({Vector3f(-4.0f, 0.5f, 0.0f), Quaternionf::Identity(), 0.7f});
  s.hypotheses.push_back({Vector3f(1.0f, 2.0f, 3.0f), Quaternionf(Eigen::AngleAxisf(0.3f, Vector3f::UnitZ())), 0.3f});
  return s;
}

float float_at(const std::string& bytes, std::size_t offset) {
  float v;
  std::memcpy(&v, bytes.data() + offset, sizeof(v));
  return v;
}

void put_float(std::string& bytes, std::size_t offset, float v) { std::memcpy(&bytes[offset], &v, sizeof(v)); }

void expect_read_error(const std::filesystem::path& file, const std::string& words) {
  tsdf_mcl::test::expect_file_error(file, words,
                                    [](const std::filesystem::path& f) { tsdf_mcl::read_particle_snapshot(f); });
}

}  // namespace

TEST(RenderParticleSnapshot, RoundTripNormalizesWeightsAndQuaternions) {
  TempDir dir;
  const ParticleSnapshot in = sample_snapshot();
  tsdf_mcl::write_particle_snapshot(dir / "p.bin", in);
  const ParticleSnapshot out = tsdf_mcl::read_particle_snapshot(dir / "p.bin");
  ASSERT_EQ(out.particles.size(), 3u);
  const float weights[] = {0.25f, 0.75f, 0.0f};
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(out.particles[i].position, in.particles[i].position);
    EXPECT_NEAR(out.particles[i].orientation.angularDistance(in.particles[i].orientation.normalized()), 0.0f, 1e-6f);
    EXPECT_NEAR(out.particles[i].orientation.norm(), 1.0f, 1e-6f);
    EXPECT_FLOAT_EQ(out.particles[i].weight, weights[i]);
  }
  ASSERT_EQ(out.hypotheses.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {  // shares as given, best first
    EXPECT_EQ(out.hypotheses[i].position, in.hypotheses[i].position);
    EXPECT_NEAR(out.hypotheses[i].orientation.angularDistance(in.hypotheses[i].orientation), 0.0f, 1e-6f);
    EXPECT_FLOAT_EQ(out.hypotheses[i].weight, in.hypotheses[i].weight);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / ("p.bin.partial-" + std::to_string(::getpid()))));
}

TEST(RenderParticleSnapshot, FileLayoutIsTheDocumentedOne) {
  TempDir dir;
  tsdf_mcl::write_particle_snapshot(dir / "p.bin", sample_snapshot());
  const std::string bytes = read_bytes(dir / "p.bin");
  ASSERT_EQ(bytes.size(), 20u + 5u * 32u);
  EXPECT_EQ(bytes.substr(0, 8), "TSDFPART");
  const auto u32 = [&](std::size_t offset) {
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k)
      v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[offset + k])) << (8 * k);
    return v;
  };
  EXPECT_EQ(u32(8), 2u);
  EXPECT_EQ(u32(12), 3u);
  EXPECT_EQ(u32(16), 2u);
  // Second record: x y z qw qx qy qz weight (the quaternion was (2, 0, 0, 0) before normalization).
  const std::size_t r = 20 + 32;
  EXPECT_FLOAT_EQ(float_at(bytes, r + 0), -4.5f);
  EXPECT_FLOAT_EQ(float_at(bytes, r + 4), 0.25f);
  EXPECT_FLOAT_EQ(float_at(bytes, r + 12), 1.0f);
  EXPECT_FLOAT_EQ(float_at(bytes, r + 16), 0.0f);
  EXPECT_FLOAT_EQ(float_at(bytes, r + 28), 0.75f);
  // The first hypothesis after the particles, its share as given.
  const std::size_t h = 20 + 3 * 32;
  EXPECT_FLOAT_EQ(float_at(bytes, h + 0), -4.0f);
  EXPECT_FLOAT_EQ(float_at(bytes, h + 28), 0.7f);
}

TEST(RenderParticleSnapshot, VersionOneFilesReadWithoutHypotheses) {
  TempDir dir;
  std::string bytes = "TSDFPART";
  for (const std::uint32_t v : {1u, 1u})
    for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
  for (const float v : {1.0f, 2.0f, 3.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f}) {
    char b[4];
    std::memcpy(b, &v, 4);
    bytes.append(b, 4);
  }
  write_bytes(dir / "v1.bin", bytes);
  const ParticleSnapshot s = tsdf_mcl::read_particle_snapshot(dir / "v1.bin");
  ASSERT_EQ(s.particles.size(), 1u);
  EXPECT_EQ(s.particles[0].position, Vector3f(1.0f, 2.0f, 3.0f));
  EXPECT_TRUE(s.hypotheses.empty());
}

TEST(RenderParticleSnapshot, EmptySnapshotRoundTrips) {
  TempDir dir;
  tsdf_mcl::write_particle_snapshot(dir / "e.bin", {});
  EXPECT_EQ(read_bytes(dir / "e.bin").size(), 20u);
  EXPECT_TRUE(tsdf_mcl::read_particle_snapshot(dir / "e.bin").particles.empty());
}

TEST(RenderParticleSnapshot, CorruptFilesGiveClearErrors) {
  TempDir dir;
  tsdf_mcl::write_particle_snapshot(dir / "good.bin", sample_snapshot());
  const std::string good = read_bytes(dir / "good.bin");

  expect_read_error(dir / "missing.bin", "does not exist");
  expect_read_error(dir.path(), "is a directory");
  write_bytes(dir / "empty.bin", "");
  expect_read_error(dir / "empty.bin", "not a particle snapshot");
  write_bytes(dir / "magic.bin", "TSDFMCL" + good.substr(7));
  expect_read_error(dir / "magic.bin", "not a particle snapshot");
  write_bytes(dir / "header.bin", good.substr(0, 12));
  expect_read_error(dir / "header.bin", "truncated");
  write_bytes(dir / "short.bin", good.substr(0, good.size() - 5));
  expect_read_error(dir / "short.bin", "truncated");
  write_bytes(dir / "long.bin", good + "xyz");
  expect_read_error(dir / "long.bin", "3 bytes after the 3 particles and 2 hypotheses");

  std::string bytes = good;
  bytes[8] = 3;
  write_bytes(dir / "version.bin", bytes);
  expect_read_error(dir / "version.bin", "unsupported version 3");

  bytes = good;
  bytes[12] = static_cast<char>(0xFF);  // a count far beyond the file's size
  bytes[15] = static_cast<char>(0xFF);
  write_bytes(dir / "count.bin", bytes);
  expect_read_error(dir / "count.bin", "truncated");

  bytes = good;
  put_float(bytes, 20 + 32 + 8, std::numeric_limits<float>::quiet_NaN());
  write_bytes(dir / "nan.bin", bytes);
  expect_read_error(dir / "nan.bin", "particle 1 has a non-finite value");

  bytes = good;
  put_float(bytes, 20 + 4 * 32 + 4, std::numeric_limits<float>::infinity());
  write_bytes(dir / "nan_hypothesis.bin", bytes);
  expect_read_error(dir / "nan_hypothesis.bin", "hypothesis 1 has a non-finite value");

  bytes = good;
  put_float(bytes, 20 + 28, -0.5f);
  write_bytes(dir / "negative.bin", bytes);
  expect_read_error(dir / "negative.bin", "particle 0 has a negative weight");

  bytes = good;
  for (int k = 0; k < 4; ++k) put_float(bytes, 20 + 64 + 12 + 4 * k, 0.0f);
  write_bytes(dir / "zeroq.bin", bytes);
  expect_read_error(dir / "zeroq.bin", "particle 2 has a zero orientation quaternion");
}

TEST(RenderParticleSnapshot, WriterRejectsBadParticlesAndPaths) {
  TempDir dir;
  ParticleSnapshot s = sample_snapshot();
  s.particles[1].weight = -1.0f;
  EXPECT_THROW(tsdf_mcl::write_particle_snapshot(dir / "a.bin", s), Error);
  s = sample_snapshot();
  s.particles[0].position.x() = std::numeric_limits<float>::infinity();
  EXPECT_THROW(tsdf_mcl::write_particle_snapshot(dir / "a.bin", s), Error);
  s = sample_snapshot();
  for (auto& p : s.particles) p.weight = 0.0f;
  EXPECT_THROW(tsdf_mcl::write_particle_snapshot(dir / "a.bin", s), Error);
  s = sample_snapshot();
  s.hypotheses[1].orientation.w() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(tsdf_mcl::write_particle_snapshot(dir / "a.bin", s), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.bin"));
  try {
    tsdf_mcl::write_particle_snapshot(dir / "no/such/folder/a.bin", sample_snapshot());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no/such/folder/a.bin"), std::string::npos) << e.what();
  }
}
