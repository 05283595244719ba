#include "dataset_source.hpp"

#include <algorithm>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::cli {
namespace {

const char* const kBagOnly[] = {"points",    "odom_frame",         "base_frame", "odom_topic",
                                "imu_topic", "ground_truth_topic", "tf_topic",   "tf_static_topic"};

}  // namespace

std::vector<OptionSpec> with_bag_options(std::vector<OptionSpec> specs) {
  const BagOptions d;
  std::vector<OptionSpec> bag = {
      {"bag", "FILE", "",
       "bag instead of --dataset (docs/bags.md): ROS 1 (.bag), or ROS 2 (rosbag2: its folder, or a .db3 or .mcap "
       "file; SQLite3 or MCAP, CDR); needs --points"},
      {"points", "TOPIC", "",
       "--bag: sensor_msgs/PointCloud2 topic of the scans (their header stamps are the scan times)"},
      {"odom_frame", "FRAME", d.odom_frame,
       "--bag: odometry from tf odom_frame -> base_frame (none if the frame is not in tf)"},
      {"base_frame", "FRAME", d.base_frame,
       "--bag: the robot's frame; tf base_frame -> the clouds' frame is the extrinsic"},
      {"odom_topic", "TOPIC", "", "--bag: nav_msgs/Odometry topic to use instead of tf odom_frame -> base_frame"},
      {"imu_topic", "TOPIC", "", "--bag: sensor_msgs/Imu topic (gravity, as a dataset's imu.txt)"},
      {"ground_truth_topic", "TOPIC", "",
       "--bag: nav_msgs/Odometry, geometry_msgs/PoseStamped or PoseWithCovarianceStamped topic of world_T_base_frame"},
      {"tf_topic", "TOPIC", d.tf_topic, "--bag: tf2_msgs/TFMessage topic of moving frames"},
      {"tf_static_topic", "TOPIC", d.tf_static_topic, "--bag: tf2_msgs/TFMessage topic of fixed frames"},
  };
  const auto it = std::find_if(specs.begin(), specs.end(), [](const OptionSpec& s) { return s.name == "dataset"; });
  // In a grouped --help (localize) the bag is input beside the dataset.
  for (OptionSpec& b : bag) b.group = it == specs.end() ? std::string() : it->group;
  specs.insert(it == specs.end() ? specs.end() : std::next(it), bag.begin(), bag.end());
  return specs;
}

Dataset open_dataset(const Options& o) {
  const bool dataset = o.has("dataset"), bag = o.has("bag");
  if (dataset && bag) throw Error("give --dataset or --bag, not both");
  if (!bag) {
    for (const char* name : kBagOnly) {
      if (o.has(name)) throw Error(std::string("--") + name + " applies to --bag only");
    }
    if (!dataset) throw Error("missing --dataset DIR or --bag FILE");
    return Dataset::open(o.text("dataset"));
  }
  if (!o.has("points")) throw Error("--bag needs --points TOPIC (the sensor_msgs/PointCloud2 topic of the scans)");
  BagOptions b;
  b.points_topic = o.text("points");
  b.odom_frame = o.text("odom_frame");
  b.base_frame = o.text("base_frame");
  b.odom_topic = o.maybe("odom_topic").value_or("");
  b.imu_topic = o.maybe("imu_topic").value_or("");
  b.ground_truth_topic = o.maybe("ground_truth_topic").value_or("");
  b.tf_topic = o.text("tf_topic");
  b.tf_static_topic = o.text("tf_static_topic");
  return Dataset::open_bag(o.text("bag"), b);
}

}  // namespace tsdf_mcl::cli
