#pragma once
// The node core in the test's own process, as a NodeLink: a NodeOutput that records what the core publishes, and
// the core's run loop on a thread of its own. Waits are on what the core published (a condition variable).
#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "localization_core.hpp"
#include "heard_record.hpp"
#include "message_checks.hpp"
#include "node_link.hpp"

namespace tsdf_mcl::node::test {

class RecordingOutput : public NodeOutput {
 public:
  explicit RecordingOutput(double transform_tolerance) : heard_(transform_tolerance) {}
  void publish_pose(const PoseOut& pose) override { heard_.pose(pose); }
  bool particles_wanted() override { return true; }
  void publish_particles(const PosesOut& p) override {
    record([&] { particles_ = p.poses.size(); });
  }
  void publish_hypotheses(const PosesOut& h) override {
    record([&] { hypotheses_ = h; });
  }
  void publish_diagnostics(const DiagnosticOut& s) override { heard_.status(s); }
  void send_transform(const TransformOut& t) override { heard_.map_odom(t); }
  void publish_map_cloud(const CloudOut& c) override {
    record([&] { map_cloud_points_ = c.cloud.layout.width; });
  }
  std::optional<Stamp> now() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return now_;
  }
  void log(LogLevel, const std::string& text) override {
    record([&] { logs_.push_back(text); });
  }
  std::string parameter_name(const std::string& name) override { return name; }
  std::string static_transform_command(const std::string& parent, const std::string& child) override {
    return "static_transform_publisher " + parent + " " + child;
  }

  void set_now(Stamp t) {
    std::lock_guard<std::mutex> lock(mutex_);
    now_ = t;
  }
  HeardRecord& heard() { return heard_; }
  bool logged(const std::string& text) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const std::string& l : logs_)
      if (l.find(text) != std::string::npos) return true;
    return false;
  }
  std::string all_logs() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string all;
    for (const std::string& l : logs_) all += l + "\n";
    return all;
  }
  std::size_t map_cloud_points() {
    std::lock_guard<std::mutex> lock(mutex_);
    return map_cloud_points_;
  }

 private:
  template <typename F>
  void record(F f) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      f();
    }
    cv_.notify_all();
  }
  HeardRecord heard_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<Stamp> now_;
  PosesOut hypotheses_;
  std::size_t particles_ = 0, map_cloud_points_ = 0;
  std::vector<std::string> logs_;
};

class DirectLink : public NodeLink {
 public:
  DirectLink(const NodeSettings& settings, const LocalizerOptions& options)
      : output_(settings.transform_tolerance), core_(settings, options, output_) {
    thread_ = std::thread([this] { core_.run([this] { return !stop_; }); });
  }
  ~DirectLink() override {
    stop_ = true;
    thread_.join();
  }
  RecordingOutput& output() { return output_; }
  LocalizationCore& core() { return core_; }

  void tf(const std::vector<TransformMsg>& transforms, bool is_static) override { core_.on_tf(transforms, is_static); }
  void cloud(const PointCloud& cloud, const RawStamp& stamp, const std::string& frame) override {
    auto encoded = std::make_shared<EncodedPointCloud2>(encode_pointcloud2(cloud));
    CloudMsg m;
    m.header = {stamp, frame};
    m.layout = encoded->layout;
    m.data = encoded->data.data();
    m.size = encoded->data.size();
    m.owner = encoded;
    output_.heard().forget(to_stamp(stamp));
    core_.on_cloud(0, m);
  }
  void odometry(const OdometryMsg& odometry) override { core_.on_odometry(odometry); }
  void imu(const ImuMsg& imu) override { core_.on_imu(imu); }
  void clock(const RawStamp& now) override {
    output_.set_now(to_stamp(now));
    core_.on_clock();
  }
  void initial_pose(const InitialPoseMsg& pose) override { core_.on_initial_pose(pose); }
  void global_localization() override { core_.request_global_localization(); }
  std::optional<Heard> heard(const RawStamp& scan, std::chrono::seconds timeout) override {
    return output_.heard().heard(to_stamp(scan), timeout);
  }
  std::optional<TransformOut> map_odom(const RawStamp& scan, std::chrono::seconds timeout) override {
    return output_.heard().map_odom(to_stamp(scan), timeout);
  }
  bool alive() override { return true; }

 private:
  RecordingOutput output_;
  LocalizationCore core_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tsdf_mcl::node::test
