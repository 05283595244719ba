#pragma once
// --dataset DIR or --bag FILE with its topics and frames: how localize, build-map and evaluate open their input.
#include <string>
#include <vector>

#include "options.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl::cli {

// `specs` with the bag options (--bag, --points, --odom_frame, --base_frame, --odom_topic, --imu_topic,
// --ground_truth_topic, --tf_topic, --tf_static_topic) inserted after its "dataset" option.
std::vector<OptionSpec> with_bag_options(std::vector<OptionSpec> specs);

// Dataset::open(--dataset) or Dataset::open_bag(--bag, the bag options). Throws Error for both or neither, or a
// bag option without --bag.
Dataset open_dataset(const Options& o);

}  // namespace tsdf_mcl::cli
