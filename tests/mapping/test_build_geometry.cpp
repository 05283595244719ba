// One check of a map build's geometry (map_builder.hpp: check_build_geometry) for build-map, the Python module and
// every builder: a voxel size the command refuses is refused by the library too, at once.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

namespace tsdf_mcl {
namespace {

std::string error_of(double voxel, double truncation, double margin) {
  try {
    check_build_geometry(voxel, truncation, margin, {"--voxel", "--truncation", "--margin"});
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(BuildGeometry, TheBuildersShareOneCheck) {
  EXPECT_EQ(error_of(0.05, 0.3, 1.0), "");
  EXPECT_EQ(error_of(0.005, 0.005, 0.0), "");  // the smallest voxel, a band of one voxel
  EXPECT_EQ(error_of(2.0, 10.0, 0.0), "");     // the largest voxel, the deepest band
  EXPECT_EQ(error_of(0.1, 6.4, 0.0), "") << "64 voxels";
  EXPECT_EQ(error_of(10, 10000, 1), "--voxel must be in 0.005..2 m, got 10");
  EXPECT_EQ(error_of(0.001, 0.3, 1), "--voxel must be in 0.005..2 m, got 0.001");
  EXPECT_EQ(error_of(std::nan(""), 0.3, 1), "--voxel must be in 0.005..2 m, got nan");
  EXPECT_EQ(error_of(0.1, 10000, 1),
            "--truncation must be in 0.1..6.4 m (at least the voxel, at most 64 voxels and 10 m), got 10000 m");
  EXPECT_NE(error_of(0.1, 6.41, 1).find("--truncation must be in 0.1..6.4 m"), std::string::npos);
  EXPECT_NE(error_of(0.1, 0.05, 1).find("--truncation must be in"), std::string::npos);
  EXPECT_NE(error_of(1.0, 10.01, 1).find("--truncation must be in 1..10 m"), std::string::npos);
  EXPECT_EQ(error_of(0.1, 0.3, -1), "--margin must not be negative");
  EXPECT_EQ(error_of(0.1, 0.3, 1.0 / 0.0), "--margin must not be negative");
  // Every builder checks the same: the mesh builder refuses 10 m voxels before it looks at the mesh.
  MeshMapOptions mesh;
  mesh.voxel_size = 10.0f;
  mesh.truncation = 10000.0f;
  try {
    build_map_from_mesh(test::box_mesh(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 1, 1)), mesh);
    ADD_FAILURE() << "built";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "voxel size must be in 0.005..2 m, got 10");
  }
  CloudMapOptions cloud;
  cloud.truncation = 4.0f;  // 80 voxels of 5 cm
  EXPECT_THROW(build_map_from_cloud(std::vector<Eigen::Vector3f>{{0, 0, 0}, {1, 1, 1}}, cloud), Error);
}

}  // namespace
}  // namespace tsdf_mcl
