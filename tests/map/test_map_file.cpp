#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/map/map_io.hpp"

using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::Error;
using tsdf_mcl::TsdfMap;
using tsdf_mcl::test::crc32_bitwise;
using tsdf_mcl::test::put_u32;
using tsdf_mcl::test::read_bytes;
using tsdf_mcl::test::TempDir;
using tsdf_mcl::test::write_bytes;

namespace {

TsdfMap sample_map() {
  TsdfMap map = TsdfMap::covering(0.05f, 0.3f, Vector3f(-1.0f, -0.5f, -0.2f), Vector3f(1.0f, 0.7f, 0.9f));
  for (int x = -10; x < 10; ++x)
    for (int y = -3; y < 5; ++y) map.set_distance({x, y, 2}, 0.01f * static_cast<float>(x + y));
  map.mark_block_free({1, 1, 1});
  map.set_unknown({0, 0, 2});
  return map;
}

void expect_load_error(const std::filesystem::path& file, const std::string& words) {
  tsdf_mcl::test::expect_file_error(file, words, [](const std::filesystem::path& f) { tsdf_mcl::load_map(f); });
}

}  // namespace

TEST(MapFile, RoundTripKeepsBuffersExactly) {
  TempDir dir;
  const TsdfMap map = sample_map();
  tsdf_mcl::save_map(map, dir / "m.tsdf");
  const TsdfMap loaded = tsdf_mcl::load_map(dir / "m.tsdf");
  EXPECT_EQ(loaded.voxel_size(), map.voxel_size());
  EXPECT_EQ(loaded.truncation(), map.truncation());
  EXPECT_EQ(loaded.min_block(), map.min_block());
  EXPECT_EQ(loaded.dims_blocks(), map.dims_blocks());
  EXPECT_EQ(loaded.coarse_index(), map.coarse_index());
  EXPECT_EQ(loaded.block_pool(), map.block_pool());
  EXPECT_FALSE(loaded.distance({0, 0, 2}).has_value());
  EXPECT_NEAR(*loaded.distance({3, 1, 2}), 0.04f, loaded.quantization_step());

  // The trailer is the standard CRC-32 of everything before it; no temporary file is left behind.
  const std::string bytes = read_bytes(dir / "m.tsdf");
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  EXPECT_EQ(stored, crc32_bitwise(bytes.substr(0, bytes.size() - 4)));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(MapFile, BadFilesSayWhatIsWrong) {
  TempDir dir;
  tsdf_mcl::save_map(sample_map(), dir / "good.tsdf");
  const std::string good = read_bytes(dir / "good.tsdf");

  expect_load_error(dir / "missing.tsdf", "does not exist");
  write_bytes(dir / "empty.tsdf", "");
  expect_load_error(dir / "empty.tsdf", "empty file");

  std::string flipped = good;
  flipped[good.size() / 2] = static_cast<char>(flipped[good.size() / 2] ^ 0x10);
  write_bytes(dir / "flipped.tsdf", flipped);
  expect_load_error(dir / "flipped.tsdf", "checksum mismatch");

  write_bytes(dir / "cut.tsdf", good.substr(0, good.size() - 100));
  expect_load_error(dir / "cut.tsdf", "truncated: expected " + std::to_string(good.size()) + " bytes, got " +
                                          std::to_string(good.size() - 100));
  write_bytes(dir / "cut_header.tsdf", good.substr(0, 20));
  expect_load_error(dir / "cut_header.tsdf", "truncated");

  std::string magic = good;
  magic[0] = 'X';
  write_bytes(dir / "magic.tsdf", magic);
  expect_load_error(dir / "magic.tsdf", "not a tsdf-mcl map");
  write_bytes(dir / "text.tsdf", "hello");
  expect_load_error(dir / "text.tsdf", "not a tsdf-mcl map");

  std::string version = good;
  put_u32(version, 8, 7);
  write_bytes(dir / "version.tsdf", version);
  expect_load_error(dir / "version.tsdf", "unsupported format version 7 (this build reads version 1)");

  write_bytes(dir / "longer.tsdf", good + "xx");
  expect_load_error(dir / "longer.tsdf", "trailing data");
}

TEST(MapFile, ValidChecksumButInconsistentContents) {
  TempDir dir;
  tsdf_mcl::save_map(sample_map(), dir / "good.tsdf");
  std::string bytes = read_bytes(dir / "good.tsdf");
  // Point the first coarse cell at a block that does not exist, then re-seal the file with a correct CRC.
  put_u32(bytes, 64, 1000000);
  put_u32(bytes, bytes.size() - 4, crc32_bitwise(bytes.substr(0, bytes.size() - 4)));
  write_bytes(dir / "bad_block.tsdf", bytes);
  expect_load_error(dir / "bad_block.tsdf", "inconsistent contents");
}

TEST(MapFile, SaveFailureThrowsAndKeepsNothingHalfWritten) {
  TempDir dir;
  EXPECT_THROW(tsdf_mcl::save_map(sample_map(), dir / "no_such_dir" / "m.tsdf"), Error);
  EXPECT_THROW(tsdf_mcl::save_map(TsdfMap(), dir / "empty.tsdf"), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "empty.tsdf"));
}

// A header with a valid checksum but a geometry whose index or scale arithmetic would overflow never loads.
TEST(MapFile, HeaderOutOfRangeIsRejectedBeforeItsPayload) {
  TempDir dir;
  tsdf_mcl::save_map(sample_map(), dir / "good.tsdf");
  const std::string good = read_bytes(dir / "good.tsdf");
  auto resealed = [&](std::size_t offset, std::uint32_t value, const std::string& name) {
    std::string bytes = good;
    put_u32(bytes, offset, value);
    put_u32(bytes, bytes.size() - 4, crc32_bitwise(bytes.substr(0, bytes.size() - 4)));
    write_bytes(dir / name, bytes);
    return dir / name;
  };
  float tiny = 1e-30f;
  std::uint32_t tiny_bits = 0;
  std::memcpy(&tiny_bits, &tiny, 4);
  expect_load_error(resealed(12, tiny_bits, "tiny_voxel.tsdf"), "voxel size");
  expect_load_error(resealed(24, 0x7FFFFFF0u, "far_x.tsdf"), "beyond the supported +-2^24");
  expect_load_error(resealed(28, 0x80000001u, "far_y.tsdf"), "beyond the supported +-2^24");
  expect_load_error(resealed(36, 0u, "no_blocks.tsdf"), "at least one block");
}
