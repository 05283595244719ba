#pragma once
// The ROS 1 node: a thin layer over tsdf_mcl::Localizer with the interface nav2 / ROS AMCL users expect, in 6-DoF.
//
// In:  PointCloud2 on `point_topics` (one or several LiDARs; each cloud moved into base_frame_id by tf, the
//      others merged into the first topic's scans), odometry from tf odom_frame_id -> base_frame_id or a
//      nav_msgs/Odometry topic, optionally sensor_msgs/Imu (gravity for the global search), /initialpose,
//      services global_localization and request_nomotion_update (std_srvs/Empty).
// Out: amcl_pose (PoseWithCovarianceStamped, full 6 x 6), particlecloud (PoseArray, decimated), ~hypotheses
//      (PoseArray, best first), tf map -> odom (REP 105, stamped scan time + transform_tolerance), ~map_cloud
//      (the map's surface, latched), /diagnostics (converged / ambiguous / searching / lost, timings, skips).
//
// Scans arrive on roscpp's spinner thread and wait in a one-deep slot; the filter runs on the caller's thread of
// run(). A scan that arrives while the previous one still waits replaces it and is counted as skipped: the node
// never falls behind the sensor.
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Empty.h>

#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::ros_node {

struct NodeSettings {
  std::string map_file;
  std::string global_frame_id = "map";
  std::string odom_frame_id = "odom";
  std::string base_frame_id = "base_link";
  std::vector<std::string> point_topics = {"points"};
  std::string odom_topic;            // empty: odometry from tf
  std::string imu_topic;             // empty: no IMU
  double transform_tolerance = 0.1;  // s added to the map -> odom stamp (nav2 AMCL's meaning)
  double tf_timeout = 0.2;           // s to wait for a transform at a scan's stamp
  double merge_window = 0.1;         // s: clouds of the other topics within this of the first topic's scan are merged
  bool tf_broadcast = true;
  int max_published_particles = 2000;
  int map_cloud_points = 300000;
};

class LocalizationNode {
 public:
  // Reads the parameters (NodeSettings by name, the filter parameters by their tsdf-mcl localize names, nav2
  // AMCL's where they exist), loads the map, advertises and subscribes. Throws Error for bad parameters or map.
  LocalizationNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  // Processes scans until ROS shuts down.
  void run();

 private:
  struct PendingCloud {
    sensor_msgs::PointCloud2ConstPtr msg;
    bool fresh = false;
  };
  void on_cloud(std::size_t topic, const sensor_msgs::PointCloud2ConstPtr& msg);
  void on_odometry(const nav_msgs::OdometryConstPtr& msg);
  void on_imu(const sensor_msgs::ImuConstPtr& msg);
  void on_initial_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& msg);
  bool on_global_localization(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool on_nomotion_update(std_srvs::Empty::Request&, std_srvs::Empty::Response&);

  void process(const sensor_msgs::PointCloud2ConstPtr& primary,
               const std::vector<sensor_msgs::PointCloud2ConstPtr>& others);
  void apply_requests(const ros::Time& stamp);
  std::optional<Pose> lookup(const std::string& target, const std::string& source, const ros::Time& stamp);
  std::optional<Pose> odometry_at(const ros::Time& stamp);
  bool add_cloud(const sensor_msgs::PointCloud2& msg, std::vector<Eigen::Vector3f>& points, bool primary);
  void publish(const ros::Time& stamp, const ScanRecord& record, const Pose& odom_T_base, double update_ms);
  void publish_status(const ros::Time& stamp, const ScanRecord* record, double update_ms);

  ros::NodeHandle nh_, private_nh_;
  NodeSettings settings_;
  TsdfMap map_;
  std::unique_ptr<Localizer> localizer_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::vector<ros::Subscriber> subscribers_;
  ros::Publisher pose_pub_, particles_pub_, hypotheses_pub_, map_cloud_pub_, diagnostics_pub_;
  std::vector<ros::ServiceServer> services_;

  // Shared with the spinner thread.
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<PendingCloud> latest_;  // per topic
  std::deque<nav_msgs::Odometry> odometry_;
  std::deque<ImuSample> imu_;
  std::optional<geometry_msgs::PoseWithCovarianceStamped> initial_pose_request_;
  bool global_request_ = false;
  bool nomotion_request_ = false;
  std::size_t skipped_ = 0;

  // The filter thread's own.
  // The last primary cloud in its own frame and that frame's extrinsic, for completing a planar /initialpose.
  std::vector<Eigen::Vector3f> last_sensor_scan_;
  std::vector<Eigen::Vector3f> scan_points_;  // the merged scan in base_frame_id, reused from scan to scan
  Pose last_base_T_sensor_ = Pose::Identity();
  std::size_t processed_ = 0, failed_ = 0, late_ = 0;
  std::optional<ros::Time> last_stamp_;
  double scan_period_ = 0.0;  // s, a running estimate from the stamps
};

}  // namespace tsdf_mcl::ros_node
