#include <gtest/gtest.h>
#include <hdf5.h>

#include <string>
#include <vector>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/h5_import.hpp"

using Eigen::Vector3i;
using tsdf_mcl::Error;
using tsdf_mcl::TsdfMap;
using tsdf_mcl::test::TempDir;

namespace {

constexpr int kN = 64;

std::uint32_t word(int mm, int weight) {
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(mm)) |
         (static_cast<std::uint32_t>(static_cast<std::uint16_t>(static_cast<std::int16_t>(weight))) << 16);
}

std::size_t at(int i, int j, int k) { return static_cast<std::size_t>((i * kN + j) * kN + k); }

// Writes datasets under /map (when `with_map`), each given as name -> (dims, type, data).
struct Dataset {
  std::string name;
  std::vector<hsize_t> dims;
  hid_t type;
  std::vector<std::uint32_t> data;
};

void write_h5(const std::filesystem::path& file, const std::vector<Dataset>& sets, bool with_map = true) {
  const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t g = H5Gcreate2(f, with_map ? "map" : "poses", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  for (const Dataset& d : sets) {
    const hid_t space = H5Screate_simple(static_cast<int>(d.dims.size()), d.dims.data(), nullptr);
    const hid_t set = H5Dcreate2(g, d.name.c_str(), d.type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(set, 0);
    ASSERT_GE(H5Dwrite(set, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.data.data()), 0);
    H5Dclose(set);
    H5Sclose(space);
  }
  H5Gclose(g);
  H5Fclose(f);
}

Dataset chunk(const std::string& name, std::vector<std::uint32_t> data) {
  return {name, {kN, kN, kN}, H5T_STD_U32LE, std::move(data)};
}

void expect_import_error(const std::filesystem::path& file, const std::string& words) {
  try {
    tsdf_mcl::import_reference_h5(file);
    FAIL() << "no error for " << file;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << "'" << what << "' lacks '" << words << "'";
  }
}

}  // namespace

TEST(H5Import, ReadsChunksWithNegativeIndicesAndUnknowns) {
  TempDir dir;
  std::vector<std::uint32_t> a(kN * kN * kN, word(0, 0));  // chunk 0_0_0: all unobserved but a few voxels
  a[at(1, 2, 3)] = word(-125, 5);
  a[at(63, 0, 0)] = word(600, 1);
  a[at(0, 63, 10)] = word(900, 2);                           // beyond the truncation: clamped
  a[at(5, 5, 5)] = word(321, 0);                             // weight 0: unobserved whatever the value
  std::vector<std::uint32_t> b(kN * kN * kN, word(600, 3));  // chunk -1_0_0: all free-space observations
  b[at(63, 0, 0)] = word(-40, 9);                            // voxel (-1, 0, 0)
  std::vector<std::uint32_t> c(kN * kN * kN, word(0, 0));
  c[at(0, 0, 63)] = word(17, 1);  // chunk 0_1_-1 -> voxel (0, 64, -1)
  write_h5(dir / "ref.h5", {chunk("0_0_0", a), chunk("-1_0_0", b), {"0_1_-1", {kN * kN * kN}, H5T_STD_I32LE, c}});

  const TsdfMap map = tsdf_mcl::import_reference_h5(dir / "ref.h5", 0.6f);
  // In a child process (as the CLI imports): the same map, and no scratch file left beside the input.
  const TsdfMap isolated = tsdf_mcl::import_reference_h5_isolated(
      dir / "ref.h5", 0.6f, std::uint64_t{tsdf_mcl::limits::kDefaultBuildMemoryMiB} << 20, dir.path());
  EXPECT_EQ(isolated.coarse_index(), map.coarse_index());
  EXPECT_EQ(isolated.block_pool(), map.block_pool());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), std::filesystem::directory_iterator()), 1);
  EXPECT_FLOAT_EQ(map.voxel_size(), 0.064f);
  EXPECT_FLOAT_EQ(map.truncation(), 0.6f);
  EXPECT_EQ(map.min_block(), Vector3i(-8, 0, -8));
  EXPECT_EQ(map.dims_blocks(), Vector3i(16, 16, 16));
  const float q = map.quantization_step();
  EXPECT_NEAR(*map.distance({1, 2, 3}), -0.125f, q);
  EXPECT_NEAR(*map.distance({63, 0, 0}), 0.6f, q);
  EXPECT_NEAR(*map.distance({0, 63, 10}), 0.6f, q);
  EXPECT_FALSE(map.distance({5, 5, 5}).has_value());
  EXPECT_FALSE(map.distance({2, 2, 3}).has_value());
  EXPECT_NEAR(*map.distance({-1, 0, 0}), -0.040f, q);
  EXPECT_NEAR(*map.distance({-64, 63, 63}), 0.6f, q);
  EXPECT_NEAR(*map.distance({0, 64, -1}), 0.017f, q);
  EXPECT_FALSE(map.distance({1, 64, -1}).has_value());
  EXPECT_FALSE(map.distance({0, 0, -1}).has_value());  // chunk 0_0_-1 is not in the file
  // World position = index * 0.064: the voxel at (1, 2, 3) is found from its metric centre.
  const auto s = map.nearest(Eigen::Vector3f(0.064f, 0.128f, 0.192f));
  ASSERT_TRUE(s.known);
  EXPECT_NEAR(s.distance, -0.125f, q);
  // Chunk -1_0_0 is all +truncation apart from one voxel: compacted into free blocks.
  EXPECT_EQ(map.stats().free_blocks, 511u);
  EXPECT_EQ(map.stats().allocated_blocks, 1u + 3u + 1u);
}

TEST(H5Import, BadFilesSayWhatIsWrong) {
  TempDir dir;
  const std::vector<std::uint32_t> zeros(kN * kN * kN, 0);
  expect_import_error(dir / "missing.h5", "does not exist");
  tsdf_mcl::test::write_bytes(dir / "text.h5", "this is not HDF5");
  expect_import_error(dir / "text.h5", "not an HDF5 file");
  write_h5(dir / "nomap.h5", {chunk("0_0_0", zeros)}, false);
  expect_import_error(dir / "nomap.h5", "no /map group");
  write_h5(dir / "empty.h5", {});
  expect_import_error(dir / "empty.h5", "no chunks");
  write_h5(dir / "name.h5", {chunk("0_0", zeros)});
  expect_import_error(dir / "name.h5", "/map/0_0 is not named like a chunk");
  write_h5(dir / "name2.h5", {chunk("1_x_2", zeros)});
  expect_import_error(dir / "name2.h5", "not named like a chunk");
  write_h5(dir / "shape.h5", {{"0_0_0", {32, 32, 32}, H5T_STD_U32LE, std::vector<std::uint32_t>(32 * 32 * 32, 0)}});
  expect_import_error(dir / "shape.h5", "64^3");
  write_h5(dir / "type.h5", {{"0_0_0", {kN, kN, kN}, H5T_IEEE_F32LE, zeros}});
  expect_import_error(dir / "type.h5", "32-bit integers");
  // A fuzzer's find: a compressed dataset whose HDF5 chunks are 2 GB (libhdf5 would allocate and fill one).
  expect_import_error(std::string(tsdf_mcl::test::test_data_dir()) + "/libhdf5_huge_chunk.h5", "corrupt");
  write_h5(dir / "dup.h5", {chunk("1_0_0", zeros), chunk("01_0_0", zeros)});
  expect_import_error(dir / "dup.h5", "two datasets");
  EXPECT_THROW(tsdf_mcl::import_reference_h5(dir / "dup.h5", 0.01f), Error);
}

// Two chunks far apart: a file of 2 MB whose bounding box in blocks would take hundreds of MB. The import stops at
// its memory budget before allocating the box.
TEST(H5Import, FarApartChunksHitTheMemoryBudget) {
  TempDir dir;
  const std::vector<std::uint32_t> observed(kN * kN * kN, word(100, 1));
  write_h5(dir / "far.h5", {chunk("0_0_0", observed), chunk("200_200_0", observed)});
  try {
    tsdf_mcl::import_reference_h5(dir / "far.h5", 0.6f, std::uint64_t{64} << 20);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget of 64 MiB"), std::string::npos) << e.what();
  }
  const TsdfMap map = tsdf_mcl::import_reference_h5(dir / "far.h5", 0.6f, std::uint64_t{512} << 20);
  EXPECT_EQ(map.dims_blocks(), Vector3i(201 * 8, 201 * 8, 8));
}
