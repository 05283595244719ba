#pragma once
// A recording as a dataset (docs/bags.md, "Reading: topics and frames"), whatever stored it: one pass over the
// store's messages on the topics BagOptions names, decoded (message_codec.hpp), then the one tf tree, odometry,
// ground truth and IMU code for ROS 1 and ROS 2 bags alike.
#include "bag_contents.hpp"
#include "message_store.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl::bag_io {

// Everything Dataset::open_bag learns from the recording but the points. Throws Error in one sentence naming the bag:
// a missing topic (with those of the type there are), a topic of the wrong type, a message that does not decode,
// frames that no tf connects, scans out of order.
BagContents read_contents(MessageStore& store, const BagOptions& options);

}  // namespace tsdf_mcl::bag_io
