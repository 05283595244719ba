// Stands in for src/io/rosbag/ where the library is built without rosbag_storage (CMake: TSDF_MCL_HAVE_ROSBAG off):
// every bag entry point says so in one sentence.
#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

[[noreturn]] void no_bag_support() {
  throw Error("built without ROS bag support: install librosbag-storage-dev (tools/setup.sh) and rebuild");
}

}  // namespace

bool Dataset::bag_support() { return false; }

Dataset Dataset::open_bag(const std::filesystem::path&, const BagOptions&) { no_bag_support(); }

struct BagWriter::Impl {};

// NOLINTNEXTLINE(performance-unnecessary-value-param): the real constructor's signature, which moves it
BagWriter::BagWriter(const std::filesystem::path&, BagWriterOptions) { no_bag_support(); }
void BagWriter::set_base_T_sensor(const Pose&) { no_bag_support(); }
BagWriter::~BagWriter() = default;
void BagWriter::add_scan(double, const PointCloud&, const std::vector<std::uint16_t>*, const std::optional<Pose>&,
                         const std::optional<Pose>&) {
  no_bag_support();
}
void BagWriter::add_imu(double, const Eigen::Vector3d&, const Eigen::Vector3d&) { no_bag_support(); }
std::size_t BagWriter::scans() const { return 0; }
void BagWriter::close() { no_bag_support(); }

}  // namespace tsdf_mcl
