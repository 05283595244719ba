// tsdf_mcl_node: 6-DoF Monte Carlo localization in a TSDF map for ROS 1 (ros1_node.hpp over the node core).
#include <ros/ros.h>

#include <exception>

#include "ros1_node.hpp"
#include "tsdf_mcl/core/one_line.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "tsdf_mcl");
  ros::NodeHandle nh, pnh("~");
  try {
    tsdf_mcl::ros_node::Ros1Node node(nh, pnh);
    ros::AsyncSpinner spinner(1);  // callbacks on their own thread; the filter runs here
    spinner.start();
    node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("tsdf_mcl: %s", tsdf_mcl::one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}
