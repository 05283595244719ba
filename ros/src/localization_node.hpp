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
// Messages a robot or a bag can get wrong (a stamp beyond 2^31 s, which ros::Duration cannot hold; a NaN, Inf or
// absurd pose; IMU or odometry out of order) are rejected, counted and named in /diagnostics: the node keeps
// running and never passes them to tf2 or the filter. Time going back (the ROS clock, or scan stamps by more than
// kTimeJumpSeconds: a bag played again, a restarted simulator) clears the tf buffer (the static transforms kept) and
// restarts the filter with a global search, as amcl does. A scan the node cannot place (no tf) is one actionable error
// in /diagnostics, retried with every scan.
//
// Scans arrive on roscpp's spinner thread and wait in a one-deep slot; the filter runs on the caller's thread of
// run(). A scan that arrives while the previous one still waits replaces it and is counted as skipped: the node
// never falls behind the sensor.
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
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
#include <tf2_msgs/TFMessage.h>

#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::ros_node {

// The heading of a pose's x axis in the world's x-y plane (rad), for logs and /diagnostics.
inline double yaw_of(const Pose& p) {
  const Eigen::Vector3d x = p.rotation().col(0);
  return std::atan2(x.y(), x.x());
}

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
  // base_frame_id -> frame, by the frame's name: the LiDAR's (or IMU's) mounting where no tf provides it (a robot
  // without robot_state_publisher, a bag recorded without /tf_static). tf wins where it has the transform.
  std::map<std::string, Pose> sensor_extrinsics;
};

class LocalizationNode {
 public:
  // Reads the parameters (NodeSettings by name, the filter parameters by their tsdf-mcl localize names, nav2
  // AMCL's where they exist), loads the map, advertises and subscribes. Throws Error for bad parameters or map.
  LocalizationNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  // Processes scans until ROS shuts down.
  void run();
  ~LocalizationNode();

 private:
  struct PendingCloud {
    sensor_msgs::PointCloud2ConstPtr msg;
    bool fresh = false;
  };
  void on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& event, bool is_static);
  void on_cloud(std::size_t topic, const sensor_msgs::PointCloud2ConstPtr& msg);
  void on_odometry(const nav_msgs::OdometryConstPtr& msg);
  void on_imu(const sensor_msgs::ImuConstPtr& msg);
  void on_initial_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& msg);
  bool on_global_localization(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool on_nomotion_update(std_srvs::Empty::Request&, std_srvs::Empty::Response&);

  void process(const sensor_msgs::PointCloud2ConstPtr& primary,
               const std::vector<sensor_msgs::PointCloud2ConstPtr>& others);
  void apply_requests(const ros::Time& stamp);
  // On failure `error` (where given) says why.
  std::optional<Pose> lookup(const std::string& target, const std::string& source, const ros::Time& stamp,
                             std::string* error = nullptr);
  std::optional<Pose> odometry_at(const ros::Time& stamp, std::string* error);
  // base_frame_id -> `frame`: from tf, else from ~sensor_extrinsics; `source` (where given) says which.
  std::optional<Pose> extrinsic(const std::string& frame, std::string* error, std::string* source = nullptr);
  bool add_cloud(const sensor_msgs::PointCloud2& msg, std::vector<Eigen::Vector3f>& points, bool primary,
                 std::string* error);
  void publish(const ros::Time& stamp, const ScanRecord& record, const Pose& odom_T_base, double update_ms);
  void publish_status(const ros::Time& stamp, const ScanRecord* record, double update_ms);
  // A scan that could not be used: /diagnostics says why (level ERROR), `problem` names what and the likely fix.
  void publish_problem(const ros::Time& stamp, const std::string& problem);
  // Counts and logs a rejected message (the caller holds mutex_).
  void reject_locked(const std::string& why);
  // Time went back (the ROS clock, or a scan stamped more than kTimeJumpSeconds before the newest; `scan_stamp`:
  // the primary topic's scan, else null): clears tf and the queues and has the filter thread restart the filter
  // (the caller holds mutex_). Returns true on such a jump.
  bool note_time_locked(const ros::Time* scan_stamp);
  void restart_after_time_jump();
  // Whether a queue whose last message is stamped `last` holds messages from before a time jump, seen from a message
  // stamped `incoming` (older than `last`): `last` lies more than kTimeJumpSeconds after the newest scan (the caller
  // holds mutex_).
  bool stale_locked(double last, double incoming) const;
  template <typename Add>
  void add_rejections(const Add& add);

  ros::NodeHandle nh_, private_nh_;
  NodeSettings settings_;
  TsdfMap map_;
  std::unique_ptr<Localizer> localizer_;
  tf2_ros::Buffer tf_buffer_;
  ros::CallbackQueue tf_queue_;
  std::unique_ptr<ros::AsyncSpinner> tf_spinner_;
  LocalizerOptions options_;  // to restart the filter after time went back
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::vector<ros::Subscriber> subscribers_, tf_subscribers_;
  ros::Publisher pose_pub_, particles_pub_, hypotheses_pub_, map_cloud_pub_, diagnostics_pub_;
  std::vector<ros::ServiceServer> services_;

  // Shared with the spinner thread.
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<PendingCloud> latest_;  // per topic
  std::deque<nav_msgs::Odometry> odometry_;
  std::condition_variable odometry_cv_;  // a new odometry message (odometry_at waits for one)
  std::deque<ImuSample> imu_;
  std::optional<geometry_msgs::PoseWithCovarianceStamped> initial_pose_request_;
  bool global_request_ = false;
  bool nomotion_request_ = false;
  std::size_t skipped_ = 0;
  std::size_t rejected_ = 0;           // messages rejected (bad stamp, non-finite, out of order)
  std::string last_rejection_;         // why the last one was
  std::optional<ros::Time> newest_;    // the newest scan stamp
  std::optional<ros::Time> last_now_;  // ros::Time::now() at the last message
  bool time_jump_pending_ = false;     // time went back: the filter thread restarts the filter
  std::size_t time_jumps_ = 0;
  std::map<std::string, geometry_msgs::TransformStamped> statics_;  // by child frame, kept across a tf clear
  std::optional<double> last_imu_time_;

  // The filter thread's own.
  // The last primary cloud in its own frame and that frame's extrinsic, for completing a planar /initialpose.
  std::vector<Eigen::Vector3f> last_sensor_scan_;
  std::vector<Eigen::Vector3f> scan_points_;  // the merged scan in base_frame_id, reused from scan to scan
  Pose last_base_T_sensor_ = Pose::Identity();
  std::string last_extrinsic_source_;  // where the last primary cloud's extrinsic came from (diagnostics)
  std::size_t processed_ = 0, failed_ = 0, late_ = 0;
  std::optional<ros::Time> last_stamp_;
  bool estimate_valid_ = false;  // the filter has processed a scan since it (re)started
  double scan_period_ = 0.0;     // s, a running estimate from the stamps
};

}  // namespace tsdf_mcl::ros_node
