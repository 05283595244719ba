// What the node publishes after a scan: the pose, the particles and hypotheses, tf map -> odom, and /diagnostics
// (the filter's state and timings, or the problem that kept the scan from the filter; rejected messages).
#include <cmath>
#include <cstdio>
#include <string>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>

#include "localization_node.hpp"
#include "ros_conversions.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::ros_node {

void LocalizationNode::publish(const ros::Time& stamp, const ScanRecord& record, const Pose& /*odom_T_base*/,
                               double update_ms) {
  const PoseEstimate& e = record.step.estimate;
  geometry_msgs::PoseWithCovarianceStamped pose;
  pose.header.stamp = stamp;
  pose.header.frame_id = settings_.global_frame_id;
  pose.pose.pose = msg_from_pose(e.pose);
  pose.pose.covariance = ros_covariance(e.pose, e.covariance);
  pose_pub_.publish(pose);

  geometry_msgs::PoseArray hypotheses;
  hypotheses.header = pose.header;
  for (const Place& h : e.places) hypotheses.poses.push_back(msg_from_pose(h.pose));
  hypotheses_pub_.publish(hypotheses);

  if (record.step.updated && particles_pub_.getNumSubscribers() > 0 && settings_.max_published_particles > 0) {
    const ParticleSnapshot snapshot = localizer_->snapshot();
    geometry_msgs::PoseArray cloud;
    cloud.header = pose.header;
    const std::size_t n = snapshot.particles.size();
    const std::size_t every = std::max<std::size_t>(
        1, (n + settings_.max_published_particles - 1) / static_cast<std::size_t>(settings_.max_published_particles));
    for (std::size_t i = 0; i < n; i += every) {
      const auto& p = snapshot.particles[i];
      geometry_msgs::Pose m;
      m.position.x = p.position.x();
      m.position.y = p.position.y();
      m.position.z = p.position.z();
      m.orientation.x = p.orientation.x();
      m.orientation.y = p.orientation.y();
      m.orientation.z = p.orientation.z();
      m.orientation.w = p.orientation.w();
      cloud.poses.push_back(m);
    }
    particles_pub_.publish(cloud);
  }
  publish_status(stamp, &record, update_ms);
}

void LocalizationNode::publish_problem(const ros::Time& stamp, const std::string& problem) {
  ROS_WARN_THROTTLE(5.0, "tsdf_mcl: scan at %.3f not used: %s", stamp.toSec(), problem.c_str());
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "tsdf_mcl: localization";
  status.hardware_id = settings_.base_frame_id;
  status.level = diagnostic_msgs::DiagnosticStatus::ERROR;
  status.message = one_line(problem);
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  add("state", "no scan used");
  add("problem", status.message);
  add("processed_scans", std::to_string(processed_));
  add("failed_scans", std::to_string(failed_));
  add_rejections(add);
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

template <typename Add>
void LocalizationNode::add_rejections(const Add& add) {
  std::lock_guard<std::mutex> lock(mutex_);
  add("rejected_messages", std::to_string(rejected_));
  add("last_rejection", last_rejection_);
  add("time_jumps", std::to_string(time_jumps_));
}

void LocalizationNode::publish_status(const ros::Time& stamp, const ScanRecord* record, double update_ms) {
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "tsdf_mcl: localization";
  status.hardware_id = settings_.base_frame_id;
  std::string state = "searching";
  std::string reason;
  std::string hypotheses;
  if (record) {
    // The library classifies (track_state.hpp); the node only reports it.
    const PoseEstimate& e = record->step.estimate;
    state = to_string(record->step.state);
    reason = to_string(record->step.reason);
    char buf[160];
    for (std::size_t i = 0; i < e.places.size() && i < 5; ++i) {
      const Place& h = e.places[i];
      std::snprintf(buf, sizeof(buf), "%s%.0f %% at (%.2f, %.2f, %.2f, yaw %.0f deg)", i ? "; " : "", 100.0 * h.weight,
                    h.pose.translation().x(), h.pose.translation().y(), h.pose.translation().z(),
                    yaw_of(h.pose) * 180.0 / M_PI);
      hypotheses += buf;
    }
  }
  status.level = state == "converged" ? diagnostic_msgs::DiagnosticStatus::OK
                 : state == "lost"    ? diagnostic_msgs::DiagnosticStatus::ERROR
                                      : diagnostic_msgs::DiagnosticStatus::WARN;
  status.message = state;
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  add("state", state);
  add("reason", reason);
  add("hypotheses", hypotheses);
  add("update_ms", std::to_string(update_ms));
  add("scan_period_ms", std::to_string(1000.0 * scan_period_));
  add("processed_scans", std::to_string(processed_));
  std::size_t skipped = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    skipped = skipped_;
  }
  add("skipped_scans", std::to_string(skipped));
  add("late_updates", std::to_string(late_));
  add("failed_scans", std::to_string(failed_));
  add_rejections(add);
  if (record) {
    add("particles", std::to_string(record->step.particles));
    add("inlier_ratio", std::to_string(record->step.estimate.inlier_ratio));
    add("map_coverage", std::to_string(record->step.estimate.coverage));
    // Places the ledger has not told from the track (place_ledger.hpp): while any is listed, `converged` is not
    // entered (a converged track keeps it until a rival is proven better).
    std::string rivals;
    char buf[96];
    for (const Pose& p : record->step.rivals) {
      std::snprintf(buf, sizeof(buf), "%s(%.2f, %.2f, %.2f)", rivals.empty() ? "" : "; ", p.translation().x(),
                    p.translation().y(), p.translation().z());
      rivals += buf;
    }
    add("rivals", rivals);
  }
  add("extrinsic", last_extrinsic_source_);  // tf, or ~sensor_extrinsics/<frame>
  add("backend", localizer_->evaluator().backend());
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

}  // namespace tsdf_mcl::ros_node
