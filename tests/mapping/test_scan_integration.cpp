#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <optional>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

using Eigen::Vector3d;
using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::Dataset;
using tsdf_mcl::Pose;
using tsdf_mcl::ScanMapOptions;
using tsdf_mcl::TsdfMap;

namespace {

// An empty box room, walls off the voxel grid.
const Vector3d kRoomLo(-2.03, -1.52, -1.01), kRoomHi(2.07, 1.48, 1.53);

// Where the ray from o along u (unit) leaves the room.
Vector3d room_hit(const Vector3d& o, const Vector3d& u) {
  double t = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (u[a] > 1e-12) t = std::min(t, (kRoomHi[a] - o[a]) / u[a]);
    if (u[a] < -1e-12) t = std::min(t, (kRoomLo[a] - o[a]) / u[a]);
  }
  return o + t * u;
}

// Signed distance to the room's walls: positive inside the room.
double room_distance(const Vector3d& p) {
  const Vector3d c = 0.5 * (kRoomLo + kRoomHi), h = 0.5 * (kRoomHi - kRoomLo);
  const Vector3d q = (p - c).cwiseAbs() - h;
  return -(q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0));
}

const std::vector<Pose> kPoses = {
    tsdf_mcl::pose_from_xyz_rpy(0.3, -0.2, 0.1, 0.0, 0.0, 0.4),
    tsdf_mcl::pose_from_xyz_rpy(-0.6, 0.35, 0.3, 0.1, -0.05, -1.2),
    tsdf_mcl::pose_from_xyz_rpy(0.8, 0.5, -0.2, -0.08, 0.1, 2.5),
};

// Scans of a sensor with rays in all directions (a Fibonacci sphere), in the sensor frame; one NaN point and
// one point too close, which the integration must skip.
void write_room_dataset(const std::filesystem::path& dir) {
  tsdf_mcl::DatasetWriter writer(dir);
  const int n = 40000;
  for (std::size_t s = 0; s < kPoses.size(); ++s) {
    tsdf_mcl::PointCloud cloud;
    const Pose world_T_sensor = kPoses[s];
    for (int i = 0; i < n; ++i) {
      const double z = 1.0 - (2.0 * i + 1.0) / n;
      const double r = std::sqrt(1.0 - z * z);
      const double phi = i * 2.399963229728653;
      const Vector3d u_sensor(r * std::cos(phi), r * std::sin(phi), z);
      const Vector3d u_world = world_T_sensor.linear() * u_sensor;
      const Vector3d hit = room_hit(world_T_sensor.translation(), u_world);
      cloud.points.push_back((world_T_sensor.inverse() * hit).cast<float>());
    }
    cloud.points.emplace_back(std::nanf(""), 0.0f, 0.0f);
    cloud.points.emplace_back(0.01f, 0.0f, 0.0f);
    writer.add(static_cast<double>(s), cloud, world_T_sensor, std::nullopt);
  }
  writer.close();
}

// One scan from `sensor` (world frame, no rotation) with a ray along each of `directions` (unit), ending where
// `hit` says (nothing where it returns no point).
template <typename Hit>
void write_one_scan(const std::filesystem::path& dir, const Vector3d& sensor, const std::vector<Vector3d>& directions,
                    Hit&& hit) {
  tsdf_mcl::DatasetWriter writer(dir);
  tsdf_mcl::PointCloud cloud;
  for (const Vector3d& u : directions) {
    if (const std::optional<Vector3d> p = hit(u)) cloud.points.push_back((*p - sensor).cast<float>());
  }
  Pose pose = Pose::Identity();
  pose.translation() = sensor;
  writer.add(0.0, cloud, pose, std::nullopt);
  writer.close();
}

}  // namespace

// A floor seen only from afar, every ray at 2.5 to 6 degrees below the horizon: along such a ray a voxel 5 cm above
// the floor lies more than the truncation before the hit, so its projective distance reads "nothing near". A
// signed distance changes by at most the distance moved: the map's must say the floor is no farther than it is.
TEST(ScanIntegration, AFloorSeenAtGrazingAnglesIsNearTheVoxelsAboveIt) {
  tsdf_mcl::test::TempDir dir;
  const Vector3d sensor(0.0, 0.0, 0.5);
  std::vector<Vector3d> directions;
  for (double elevation = -6.0; elevation <= -2.5; elevation += 0.05) {
    for (double azimuth = -20.0; azimuth <= 20.0; azimuth += 0.1) {
      const double e = elevation * M_PI / 180.0, a = azimuth * M_PI / 180.0;
      directions.emplace_back(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
    }
  }
  write_one_scan(dir.path(), sensor, directions,
                 [&](const Vector3d& u) -> std::optional<Vector3d> { return sensor + (-sensor.z() / u.z()) * u; });
  ScanMapOptions options;
  options.voxel_size = 0.05f;
  options.truncation = 0.3f;
  const TsdfMap map = tsdf_mcl::build_map_from_scans(Dataset::open(dir.path()), {0}, options);
  std::size_t checked = 0;
  for (double x = 6.0; x <= 9.0; x += 0.25) {
    const auto floor = map.nearest(Vector3f(static_cast<float>(x), 0.0f, 0.0f));
    ASSERT_TRUE(floor.known) << x;
    // The floor's own voxel reads a few cm: grazing rays through its upper half end farther on (a bias the
    // projective distance keeps); what must not happen is the voxels above reading "nothing near".
    EXPECT_LT(std::abs(floor.distance), 0.15f) << x;
    for (const double z : {0.05, 0.1, 0.15}) {
      const auto above = map.nearest(Vector3f(static_cast<float>(x), 0.0f, static_cast<float>(z)));
      if (!above.known) continue;
      ++checked;
      EXPECT_GT(above.distance, 0.0f) << x << " " << z;
      EXPECT_LE(above.distance, floor.distance + z + 0.01) << x << " " << z << ": the floor lies " << z << " m below";
    }
  }
  EXPECT_GT(checked, 20u);
}

// Rays that pass above a floor no ray ever reached (a room seen only through its door, here a sensor whose rays
// all point level or up) prove the voxels they cross free, not the rest of their blocks: the floor's voxels stay
// unknown rather than being claimed free space, while the space the rays crossed is free.
TEST(ScanIntegration, AFloorNoRayReachedStaysUnknownUnderCrossedSpace) {
  tsdf_mcl::test::TempDir dir;
  const Vector3d sensor(0.0, 0.0, 0.2);
  std::vector<Vector3d> directions;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {  // the upper half of a Fibonacci sphere
    const double z = (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z), phi = i * 2.399963229728653;
    directions.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  // A box room 8 x 8 m, its ceiling at 2.5 m (the floor, at -1 m, is below every ray).
  write_one_scan(dir.path(), sensor, directions, [&](const Vector3d& u) -> std::optional<Vector3d> {
    double t = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 2; ++a) {
      if (std::abs(u[a]) > 1e-12) t = std::min(t, (4.0 * (u[a] > 0 ? 1 : -1) - sensor[a]) / u[a]);
    }
    if (u.z() > 1e-12) t = std::min(t, (2.5 - sensor.z()) / u.z());
    return sensor + t * u;
  });
  ScanMapOptions options;
  options.voxel_size = 0.05f;
  options.truncation = 0.3f;
  const TsdfMap map = tsdf_mcl::build_map_from_scans(Dataset::open(dir.path()), {0}, options);
  for (const double x : {-2.0, -1.0, 1.0, 2.0}) {
    for (const double y : {-2.0, 1.5}) {
      const auto crossed = map.nearest(Vector3f(static_cast<float>(x), static_cast<float>(y), 0.25f));
      ASSERT_TRUE(crossed.known) << x << " " << y;
      EXPECT_GT(crossed.distance, 0.0f);
      EXPECT_FALSE(map.nearest(Vector3f(static_cast<float>(x), static_cast<float>(y), 0.0f)).known)
          << x << " " << y << ": no ray came below 0.2 m";
    }
  }
  EXPECT_GT(map.stats().free_blocks, 50u) << "inside the seen space, whole blocks are still free";
}

TEST(ScanIntegration, BoxRoomDistancesFreeSpaceAndUnknownOutside) {
  tsdf_mcl::test::TempDir dir;
  write_room_dataset(dir.path());
  const Dataset dataset = Dataset::open(dir.path());
  ScanMapOptions options;
  options.voxel_size = 0.05f;
  options.truncation = 0.2f;
  options.margin = 0.5f;
  std::vector<std::size_t> calls;
  const TsdfMap map = tsdf_mcl::build_map_from_scans(dataset, {0, 1, 2}, options,
                                                     [&](std::size_t done, std::size_t) { calls.push_back(done); });
  ASSERT_FALSE(calls.empty());
  EXPECT_EQ(calls.back(), 12u);  // four passes over three scans

  const float trunc = options.truncation;
  std::size_t near_wall = 0, behind_wall = 0;
  const Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) {
        const Vector3i v(x, y, z);
        const Vector3d p = map.center_of(v).cast<double>();
        const double d = room_distance(p);
        const std::optional<float> got = map.distance(v);
        if (got) {
          ASSERT_TRUE(std::isfinite(*got));
        }
        // Outside the room beyond the band no ray ever went: unknown.
        if (d < -trunc - 0.05) {
          ASSERT_FALSE(got.has_value()) << v.transpose() << " d " << d;
          continue;
        }
        // The projective distance along a ray that meets the wall at angle theta is d / cos(theta). Where every
        // sensor sees the wall within 25 degrees of its normal, the average lies in [d, d / cos 25deg], up to
        // how far a ray through the voxel passes from its centre (half a voxel diagonal, times tan 25deg).
        // The wall normal where the closest point lies on a face (not an edge or corner), else zero.
        const Vector3d normal = [&] {
          const Vector3d c = 0.5 * (kRoomLo + kRoomHi), h = 0.5 * (kRoomHi - kRoomLo);
          const Vector3d q = (p - c).cwiseAbs() - h;
          int axis;
          const double top = q.maxCoeff(&axis);
          Vector3d others = q;
          others[axis] = -std::numeric_limits<double>::infinity();
          Vector3d n = Vector3d::Zero();
          if (top - others.maxCoeff() > 0.1) n[axis] = p[axis] > c[axis] ? 1.0 : -1.0;
          return n;
        }();
        bool head_on = normal.squaredNorm() > 0.0;
        for (const Pose& pose : kPoses) {
          const Vector3d to_voxel = (p - pose.translation()).normalized();
          head_on = head_on && to_voxel.dot(normal) > std::cos(25.0 * M_PI / 180.0);
        }
        if (!head_on || std::abs(d) > 0.15) continue;
        ASSERT_TRUE(got.has_value()) << v.transpose() << " d " << d;
        const double slack =
            0.5 * std::sqrt(3.0) * 0.05 * std::tan(25.0 * M_PI / 180.0) + 2.0 * map.quantization_step();
        if (d >= 0.0) {
          ++near_wall;
          EXPECT_GE(*got, d - slack) << v.transpose();
          EXPECT_LE(*got, d / std::cos(25.0 * M_PI / 180.0) + slack) << v.transpose();
        } else {
          ++behind_wall;
          EXPECT_LE(*got, d + slack) << v.transpose();
          EXPECT_GE(*got, d / std::cos(25.0 * M_PI / 180.0) - slack) << v.transpose();
        }
      }
  EXPECT_GT(near_wall, 200u);
  EXPECT_GT(behind_wall, 200u);

  // The middle of the room is carved free.
  for (double x = -1.2; x <= 1.2; x += 0.1)
    for (double y = -0.8; y <= 0.8; y += 0.1)
      for (double z = -0.4; z <= 0.9; z += 0.1) {
        const auto s = map.nearest(Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
        ASSERT_TRUE(s.known) << x << " " << y << " " << z;
        ASSERT_FLOAT_EQ(s.distance, trunc);
      }
  EXPECT_GT(map.stats().free_blocks, 50u);
}

TEST(ScanIntegration, RejectsBadInput) {
  tsdf_mcl::test::TempDir dir;
  write_room_dataset(dir.path());
  const Dataset dataset = Dataset::open(dir.path());
  ScanMapOptions options;
  EXPECT_THROW(tsdf_mcl::build_map_from_scans(dataset, {}, options), tsdf_mcl::Error);
  EXPECT_THROW(tsdf_mcl::build_map_from_scans(dataset, {7}, options), tsdf_mcl::Error);
  ScanMapOptions bad = options;
  bad.truncation = 0.01f;
  EXPECT_THROW(tsdf_mcl::build_map_from_scans(dataset, {0}, bad), tsdf_mcl::Error);
  bad = options;
  bad.min_range = 50.0f;
  try {
    tsdf_mcl::build_map_from_scans(dataset, {0}, bad);
    FAIL();
  } catch (const tsdf_mcl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("range limits"), std::string::npos) << e.what();
  }
}

TEST(ScanIntegration, BalmEvenScansMatchHeldOutScans) {
  const auto dir = tsdf_mcl::test::shared_data() / "balm_realworld";
  if (!std::filesystem::exists(dir / "poses.txt")) GTEST_SKIP() << "shared data not found: " << dir;
  const Dataset dataset = Dataset::open(dir);
  ScanMapOptions options;
  options.voxel_size = 0.1f;
  const std::vector<std::size_t> scans = tsdf_mcl::ScanSelection{0, 8, 0}.indices(dataset.size());
  ASSERT_EQ(scans.size(), 23u);
  const TsdfMap map = tsdf_mcl::build_map_from_scans(dataset, scans, options);
  const TsdfMap::Stats s = map.stats();
  EXPECT_GT(s.allocated_blocks, 2000u);
  EXPECT_LT(s.allocated_blocks, 60000u);
  // A courtyard of about 18 x 20 m, several metres high.
  const double free_m3 = static_cast<double>(s.free_voxels) * std::pow(options.voxel_size, 3);
  EXPECT_GT(free_m3, 1500.0);
  EXPECT_LT(free_m3, 40000.0);

  // Every sensor position, including the odd scans' that the map never saw, lies in known free space; the odd
  // scans' points lie on the map's surfaces.
  std::size_t in_free = 0;
  std::vector<float> residuals;
  for (std::size_t i = 1; i < dataset.size(); i += 2) {
    const auto at_sensor = map.trilinear(dataset.pose(i).translation().cast<float>());
    in_free += at_sensor.known && at_sensor.distance > 0.0f;
    const tsdf_mcl::PointCloud cloud = dataset.load_scan(i);
    for (std::size_t k = 0; k < cloud.size(); k += 97) {
      if (cloud.points[k].norm() < 2.0f) continue;
      const auto sample = map.trilinear((dataset.pose(i) * cloud.points[k].cast<double>()).cast<float>());
      if (sample.known) residuals.push_back(std::abs(sample.distance));
    }
  }
  EXPECT_GE(in_free, 85u);  // of 88
  ASSERT_GT(residuals.size(), 20000u);
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  EXPECT_LT(residuals[residuals.size() / 2], 0.05f);
}
