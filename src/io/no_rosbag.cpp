// Stands in for src/io/rosbag/ where the library is built without rosbag_storage (CMake: TSDF_MCL_HAVE_ROSBAG off):
// ROS 1 bags are refused in one sentence; rosbag2 recordings (src/io/rosbag2/) are read and written all the same.
#include "bag/bag_formats.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::bag_io {
namespace {

[[noreturn]] void no_ros1_support(const std::filesystem::path& file) {
  throw Error(file.string() +
              " is a ROS 1 bag: built without ROS 1 bag support; install librosbag-storage-dev (tools/setup.sh) and "
              "rebuild");
}

}  // namespace

bool ros1_bag_support() { return false; }

OpenedBag open_ros1_bag(const std::filesystem::path& file, const BagOptions&) { no_ros1_support(file); }

std::unique_ptr<BagSink> make_ros1_sink(const std::filesystem::path& file, const BagWriterOptions&) {
  no_ros1_support(file);
}

}  // namespace tsdf_mcl::bag_io
