#pragma once
// The command-line tests' small synthetic office: a map file and a 24-scan dataset along the test trajectory
// (ground truth, drifting odometry), built once per test binary.
#include <string>

#include "filter_test_scene.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl::test {

inline constexpr double kT0 = 1630577758.569490;  // unix time: needs all digits of %.9f

// The office scene as a dataset: `n` scans along the test trajectory, ground truth and drifting odometry.
inline void write_office_dataset(const std::filesystem::path& dir, std::size_t n) {
  const std::vector<test::Box> boxes = test::office_boxes();
  const std::vector<Pose> truth = test::office_trajectory(n);
  const std::vector<Pose> odom = test::drifting_odometry(truth, 5);
  Rng rng(3);
  DatasetWriter writer(dir);
  for (std::size_t i = 0; i < n; ++i) {
    PointCloud cloud;
    cloud.points = test::simulate_scan(boxes, truth[i], rng);
    writer.add(kT0 + 0.5 * static_cast<double>(i), cloud, truth[i], odom[i]);
  }
  writer.close();
}

// Built once: the office map file and a 24-scan dataset.
struct Fixture {
  TempDir dir;
  std::string map, dataset;
  Fixture() {
    map = (dir / "office.tsdf").string();
    dataset = (dir / "office").string();
    save_map(test::make_office_map(), map);
    write_office_dataset(dataset, 24);
  }
};

inline const Fixture& fixture() {
  static const Fixture f;
  return f;
}

}  // namespace tsdf_mcl::test
