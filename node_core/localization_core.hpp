#pragma once
// The localization node without its transport: what the ROS 1 node (ros/) and the ROS 2 node over DDS (ros2/) both
// are, over tsdf_mcl::Localizer, with the interface nav2 / ROS AMCL users expect, in 6-DoF. A transport converts its
// messages to node_messages.hpp, calls the on_* members from its threads and run() on one of its own, and publishes
// what the core hands to its NodeOutput.
//
// In:  clouds on `point_topics` (one or several LiDARs; each moved into base_frame_id by tf, the others merged into
//      the first topic's scans), odometry from tf odom_frame_id -> base_frame_id or an Odometry topic, optionally an
//      IMU (gravity for the global search), /initialpose, requests for a global search or an update without motion.
// Out: amcl_pose (full 6 x 6 covariance), the particle cloud (decimated), the ranked hypotheses, tf map -> odom
//      (REP 105, stamped scan time + transform_tolerance), the map's surface (once), /diagnostics (the state and its
//      reason, timings, skips, rejections).
//
// Messages a robot or a bag can get wrong (a stamp ROS time cannot hold, a NaN, Inf, absurd or off-map pose, a
// quaternion that is not one, IMU or odometry out of order) are rejected, counted and named in /diagnostics
// (message_checks.hpp): the node keeps running and never passes them to tf or the filter. Time going back (the ROS
// clock, or scan stamps by more than kTimeJumpSeconds: a bag played again, a restarted simulator) clears tf (the
// static transforms kept) and restarts the filter with a global search, as amcl does. A scan the node cannot place
// (no tf) is one actionable error in /diagnostics, retried with every scan.
//
// Scans wait in a one-deep slot per topic; the filter runs on the thread that calls run(). A scan that arrives while
// the previous one still waits replaces it and is counted as skipped: the node never falls behind the sensor.
//
// The last converged pose is kept in settings.last_pose_file (at most once a second); a restarted node starts there
// if the file is for this map, and searches the whole map if the first scan does not fit there.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "node_messages.hpp"
#include "node_output.hpp"
#include "node_parameters.hpp"
#include "transform_buffer.hpp"
#include "tsdf_mcl/localizer/last_pose_file.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::node {

class LocalizationCore {
 public:
  // Loads the map, starts the localizer (from the last pose file where it has a pose for this map and no initial
  // pose was given), publishes the map's surface. Throws Error for a bad map or options.
  LocalizationCore(const NodeSettings& settings, const LocalizerOptions& options, NodeOutput& output);
  // Keeps the newest converged pose in the last pose file (the node stops where the robot stands).
  ~LocalizationCore();

  // From the transport's threads.
  void on_tf(const std::vector<TransformMsg>& transforms, bool is_static);
  void on_cloud(std::size_t topic, const CloudMsg& cloud);  // topic: index into settings.point_topics
  void on_odometry(const OdometryMsg& odometry);
  void on_imu(const ImuMsg& imu);
  void on_initial_pose(const InitialPoseMsg& pose);
  void request_global_localization();
  void request_nomotion_update();
  // The ROS clock moved (a /clock message): time going back restarts tf and the filter.
  void on_clock();

  // Processes scans until `ok` turns false (it is asked at least every 100 ms).
  void run(const std::function<bool()>& ok);

  const NodeSettings& settings() const { return settings_; }
  const std::string& backend_note() const { return localizer_->backend_note(); }

 private:
  struct Pending {
    std::optional<CloudMsg> cloud;
    Stamp stamp;
    bool fresh = false;
  };
  struct TimedOdometry {
    Stamp stamp;
    Pose pose;
  };
  struct Counters {
    std::size_t processed = 0, failed = 0, late = 0;
    std::size_t initial_poses = 0, global_searches = 0;  // requests applied
  };

  void process(const CloudMsg& primary, Stamp stamp, const std::vector<CloudMsg>& others);
  void apply_requests(Stamp stamp);
  std::optional<Pose> odometry_at(Stamp stamp, std::string* error);
  // base_frame_id -> `frame`: from tf, else from sensor_extrinsics; `source` (where given) says which.
  std::optional<Pose> extrinsic(const std::string& frame, std::string* error, std::string* source = nullptr);
  bool add_cloud(const CloudMsg& msg, std::vector<Eigen::Vector3f>& points, bool primary, std::string* error);
  void broadcast_map_to_odom(Stamp stamp, const Pose& map_T_base, const Pose& odom_T_base);
  // After an update: a start from the last pose whose first scan did not fit there searches the whole map; a
  // converged estimate is kept in the file.
  void follow_last_pose(const ScanRecord& record);

  // node_status.cpp: what the node publishes after a scan.
  void publish(Stamp stamp, const ScanRecord& record, double update_ms);
  void publish_status(Stamp stamp, const ScanRecord& record, double update_ms);
  // A scan that could not be used: /diagnostics says why (level ERROR), `problem` names what and the likely fix.
  void publish_problem(Stamp stamp, const std::string& problem);
  void add_rejections(DiagnosticOut& status);
  // The initial poses and global searches requested and applied so far.
  void add_requests(DiagnosticOut& status) const;

  // node_callbacks.cpp: the checks and the clock.
  // Counts and logs a rejected message (the caller holds mutex_).
  void reject_locked(const std::string& why);
  // A usable stamp, or nullopt after rejecting the message as `what` (the caller holds mutex_).
  std::optional<Stamp> checked_stamp_locked(const RawStamp& stamp, const std::string& what);
  // Time went back (the ROS clock, or a scan stamped more than kTimeJumpSeconds before the newest; `scan_stamp`:
  // the primary topic's scan, else null): clears tf and the queues and has the filter thread restart the filter
  // (the caller holds mutex_). Returns true on such a jump.
  bool note_time_locked(const Stamp* scan_stamp);
  void restart_after_time_jump();
  // Whether a queue whose last message is stamped `last` holds messages from before a time jump, seen from a message
  // stamped `incoming` (older than `last`): `last` lies more than kTimeJumpSeconds after the newest scan (the caller
  // holds mutex_).
  bool stale_locked(Stamp last, Stamp incoming) const;
  // A log line at most every `seconds` per `key` (a stream of the same problem does not flood the log).
  void log_throttled(const std::string& key, double seconds, LogLevel level, const std::string& text);

  NodeSettings settings_;
  LocalizerOptions options_;  // to restart the filter after time went back
  NodeOutput& out_;
  TsdfMap map_;
  std::unique_ptr<Localizer> localizer_;
  TransformBuffer tf_;
  std::unique_ptr<LastPoseFile> last_pose_;

  // Shared with the transport's threads.
  std::mutex mutex_;
  std::condition_variable scan_cv_;      // a new scan on the first topic
  std::condition_variable odometry_cv_;  // a new odometry message (odometry_at waits for one)
  std::vector<Pending> latest_;          // per topic
  std::deque<TimedOdometry> odometry_;
  std::deque<ImuSample> imu_;
  std::optional<Pose> initial_pose_request_;
  bool global_request_ = false;
  bool nomotion_request_ = false;
  std::size_t skipped_ = 0;
  std::size_t rejected_ = 0;        // messages rejected (bad stamp, non-finite, out of order)
  std::string last_rejection_;      // why the last one was
  std::optional<Stamp> newest_;     // the newest scan stamp
  std::optional<Stamp> last_now_;   // the ROS clock at the last message
  bool time_jump_pending_ = false;  // time went back: the filter thread restarts the filter
  std::size_t time_jumps_ = 0;
  std::optional<Stamp> last_imu_time_;
  std::map<std::string, std::chrono::steady_clock::time_point> throttled_;  // log_throttled's last line per key
  std::mutex log_mutex_;

  // The filter thread's own.
  // The last primary cloud in its own frame and that frame's extrinsic, for completing a planar /initialpose.
  std::vector<Eigen::Vector3f> last_sensor_scan_;
  std::vector<Eigen::Vector3f> scan_points_;  // the merged scan in base_frame_id, reused from scan to scan
  Pose last_base_T_sensor_ = Pose::Identity();
  std::string last_extrinsic_source_;  // where the last primary cloud's extrinsic came from (diagnostics)
  Counters counters_;
  std::optional<Stamp> last_stamp_;
  bool estimate_valid_ = false;  // the filter has processed a scan since it (re)started
  double scan_period_ = 0.0;     // s, a running estimate from the stamps
};

}  // namespace tsdf_mcl::node
