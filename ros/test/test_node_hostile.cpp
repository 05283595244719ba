// The node against what real robots and bags send it: a missing extrinsic, messages out of order, stamps ROS time
// cannot hold, NaN and absurd poses, time going back; and bad parameters or a missing map at start. The test itself
// publishes the messages (no bag): each step waits for the node's /diagnostics on a scan, never a fixed time.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <condition_variable>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>

#include "node_test_support.hpp"
#include "ros_conversions.hpp"

namespace tsdf_mcl::ros_node {
namespace {

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The node's statuses by scan stamp, and its poses.
class Listener {
 public:
  explicit Listener(ros::NodeHandle& nh) {
    subs_.push_back(nh.subscribe("/diagnostics", 100, &Listener::on_status, this));
    subs_.push_back(nh.subscribe("/amcl_pose", 100, &Listener::on_pose, this));
  }
  void on_status(const diagnostic_msgs::DiagnosticArrayConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& s : m->status) {
      if (s.name == "tsdf_mcl: localization") statuses_[m->header.stamp] = s;
    }
    cv_.notify_all();
  }
  void on_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    poses_[m->header.stamp] = *m;
    cv_.notify_all();
  }
  std::optional<diagnostic_msgs::DiagnosticStatus> wait_status(const ros::Time& stamp, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return statuses_.count(stamp) > 0; })) return std::nullopt;
    return statuses_.at(stamp);
  }
  // The pose for a scan, waiting for it: the node publishes it before the scan's status, but on another topic,
  // so it may reach this process after the status. For a scan that got no pose, check its status first: then a pose
  // that has not arrived will not (no wait needed).
  std::optional<geometry_msgs::PoseWithCovarianceStamped> pose(const ros::Time& stamp,
                                                               std::chrono::seconds timeout = 60s) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return poses_.count(stamp) > 0; })) return std::nullopt;
    return poses_.at(stamp);
  }
  bool has_pose(const ros::Time& stamp) {
    std::lock_guard<std::mutex> lock(mutex_);
    return poses_.count(stamp) > 0;
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::map<ros::Time, diagnostic_msgs::DiagnosticStatus> statuses_;
  std::map<ros::Time, geometry_msgs::PoseWithCovarianceStamped> poses_;
  std::vector<ros::Subscriber> subs_;
};

std::string value(const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
  for (const auto& kv : s.values)
    if (kv.key == key) return kv.value;
  return "";
}

std::size_t count(const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
  const std::string v = value(s, key);
  return v.empty() ? 0 : std::stoul(v);
}

geometry_msgs::TransformStamped transform(const std::string& parent, const std::string& child, const ros::Time& t,
                                          double x) {
  geometry_msgs::TransformStamped m;
  m.header.stamp = t;
  m.header.frame_id = parent;
  m.child_frame_id = child;
  m.transform.translation.x = x;
  m.transform.translation.z = x == 0.0 ? 0.5 : 0.0;
  m.transform.rotation.w = 1.0;
  return m;
}

// Starts the node with `params`; returns its exit status once it ended within 60 s (-1: still running).
int start_and_exit(const std::vector<std::string>& params, const fs::path& log) {
  // A name of its own: parameters stay on the master after a node ends.
  static int started = 0;
  std::vector<std::string> args = {TSDF_MCL_NODE, "__name:=tsdf_mcl_bad" + std::to_string(started++)};
  args.insert(args.end(), params.begin(), params.end());
  Child node(args, log);
  return node.wait_for(60s);
}

// Bad starts: one error naming what is wrong, exit status 1.
void expect_bad_starts_refused(const fs::path& dir, const std::string& map) {
  struct BadStart {
    std::vector<std::string> params;
    std::string error;
  };
  const std::vector<BadStart> bad = {
      {{"_map_file:=" + (dir / "missing.tsdf").string()}, "missing.tsdf"},
      {{map, "_transform_tolerance:=.nan"}, "~transform_tolerance must be a number in 0..60, got"},
      {{map, "_transform_tolerance:=abc"}, "~transform_tolerance must be a number in 0..60, got 'abc'"},
      {{map, "_map_cloud_points:=1000000000000"},
       "~map_cloud_points must be a whole number in 0..1e+08, got 1000000000000"},
      {{map, "_sensor_extrinsics/lidar:=0 0 0.5"},
       "~sensor_extrinsics/lidar must be x, y, z, roll, pitch, yaw (m, and radians or e.g. 90deg), got '0 0 0.5'"},
      {{map, "_sensor_extrinsics/lidar:=0 0 500 0 0 0"},
       "~sensor_extrinsics/lidar's z must be a number in -100..100 m, got '500'"},
      {{map, "_sensor_extrinsics/lidar:=0 0 0.5 0 0 90"}, "~sensor_extrinsics/lidar's yaw 90 is more than"},
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    const fs::path node_log = dir / ("bad" + std::to_string(i) + ".log");
    EXPECT_EQ(start_and_exit(bad[i].params, node_log), 1) << bad[i].error;
    const std::string text = read_text(node_log);
    EXPECT_NE(text.find(bad[i].error), std::string::npos) << text;
  }
}

// A running node and the test's publishers, and the steps the test takes it through. A step's ASSERT ends the step;
// the test then ends too (it checks HasFatalFailure after each step that has one).
class HostileSession {
 public:
  static constexpr auto kError = diagnostic_msgs::DiagnosticStatus::ERROR;

  HostileSession(const fs::path& dir, const std::string& map)
      : dir_(dir),
        listener_(nh_),
        points_(nh_.advertise<sensor_msgs::PointCloud2>("/points", 10)),
        odom_(nh_.advertise<nav_msgs::Odometry>("/odom", 100)),
        imu_(nh_.advertise<sensor_msgs::Imu>("/imu", 100)),
        tf_(nh_.advertise<tf2_msgs::TFMessage>("/tf", 100)),
        tf_static_(nh_.advertise<tf2_msgs::TFMessage>("/tf_static", 10, true)),
        initial_pose_(nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("/initialpose", 10)),
        spinner_(2) {
    spinner_.start();
    node_.emplace(
        std::vector<std::string>{TSDF_MCL_NODE, "__name:=tsdf_mcl", map, "_point_topics:=/points", "_odom_topic:=/odom",
                                 "_imu_topic:=/imu", "_backend:=cpu", "_particles:=3000", "_seed:=1",
                                 // The mounting of a second LiDAR frame that no tf knows (as roscpp
                                 // passes it: text).
                                 "_sensor_extrinsics/lidar_b:=[0, 0, 0.5, 0, 0, 90deg]"},
        dir / "node.log");
  }

  Child& node() { return *node_; }

  void wait_until_up() {
    ASSERT_TRUE(ros::service::waitForService("/global_localization", ros::Duration(120.0)))
        << "the node did not come up; see " << dir_ / "node.log";
    for (ros::Publisher* p : {&points_, &odom_, &imu_, &tf_, &tf_static_, &initial_pose_}) {
      ASSERT_TRUE(wait_until([&] { return p->getNumSubscribers() > 0; }, 60s)) << p->getTopic();
    }
    // A ring of wall points 3 m around the sensor: enough for the filter to run (the pose does not matter here).
    PointCloud ring;
    for (int i = 0; i < 720; ++i) {
      const float a = static_cast<float>(i) * 0.0087266f;
      ring.points.emplace_back(3.0f * std::cos(a), 3.0f * std::sin(a), static_cast<float>(i % 8) * 0.2f - 0.6f);
    }
    cloud_ = msg_from_cloud(ring);
    cloud_.header.frame_id = "lidar";
  }

  // 1. No base_link -> lidar anywhere: one actionable error per scan, nothing invented.
  void missing_extrinsic() {
    odometry(now_, 0.0);
    s_ = scan();
    EXPECT_EQ(s_.level, diagnostic_msgs::DiagnosticStatus::ERROR);
    EXPECT_NE(s_.message.find("no transform base_link -> lidar"), std::string::npos) << s_.message;
    EXPECT_NE(s_.message.find("static_transform_publisher"), std::string::npos) << s_.message;
    EXPECT_EQ(s_.message.find('\n'), std::string::npos);
    EXPECT_FALSE(listener_.has_pose(ros::Time(now_)));
  }

  // 2. The extrinsic appears (latched, as a robot_state_publisher started late sends it): the node recovers.
  void extrinsic_appears() {
    statics_.transforms.push_back(transform("base_link", "lidar", ros::Time(now_), 0.0));
    tf_static_.publish(statics_);
    s_ = scan_until([](const auto& st) { return count(st, "processed_scans") > 0; });
    EXPECT_NE(s_.level, diagnostic_msgs::DiagnosticStatus::ERROR) << s_.message;
    ASSERT_TRUE(listener_.pose(ros::Time(now_)));
  }

  // 3. Hostile messages: each rejected and counted, the node keeps going.
  void hostile_messages() {
    rejected_ = count(s_, "rejected_messages");
    imu_sample(now_ + 0.02, 9.81);
    imu_sample(now_ - 0.5, 9.81);  // older than the last sample
    expect_rejected("IMU out of order", "not after the previous sample");
    imu_sample(now_ + 0.02, std::numeric_limits<double>::quiet_NaN());
    expect_rejected("NaN IMU", "not finite");
    {
      nav_msgs::Odometry m;
      m.header.stamp = ros::Time(3000000000u, 0);
      m.header.frame_id = "odom";
      m.pose.pose.orientation.w = 1.0;
      odom_.publish(m);
    }
    expect_rejected("odometry at 3e9 s", "odometry on /odom: stamp 3000000000 s is beyond 2^31 s");
    {
      tf2_msgs::TFMessage m;
      m.transforms.push_back(transform("odom", "base_link", ros::Time(4294967290u, 0), 1.0));
      tf_.publish(m);
    }
    expect_rejected("tf near 2^32 s", "/tf odom -> base_link: stamp 4294967290 s is beyond 2^31 s");
    odometry(now_ + 0.02, std::numeric_limits<double>::quiet_NaN());
    expect_rejected("NaN odometry", "non-finite pose");
    for (const double bad_x :
         {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300}) {
      geometry_msgs::PoseWithCovarianceStamped m;
      m.header.frame_id = "map";
      m.pose.pose.position.x = bad_x;
      m.pose.pose.orientation.w = 1.0;
      initial_pose_.publish(m);
      expect_rejected("/initialpose at x " + std::to_string(bad_x), "/initialpose");
    }
    const auto pose = listener_.pose(ros::Time(now_));
    ASSERT_TRUE(pose) << "no pose for the last scan";
    EXPECT_TRUE(std::isfinite(pose->pose.pose.position.x) && std::isfinite(pose->pose.pose.position.y) &&
                std::isfinite(pose->pose.pose.position.z));
  }

  // 4. The cloud's frame changes to one tf does not know: ~sensor_extrinsics gives its mounting. A frame neither knows
  //    is the ERROR of step 1, naming the parameter as a fix too; back in the first frame, tf serves again.
  void frame_changes() {
    cloud_.header.frame_id = "lidar_b";
    s_ = scan();
    EXPECT_NE(s_.level, kError) << s_.message;
    EXPECT_EQ(value(s_, "extrinsic"), "~sensor_extrinsics/lidar_b");
    EXPECT_TRUE(listener_.pose(ros::Time(now_)));
    cloud_.header.frame_id = "lidar_c";
    s_ = scan();
    EXPECT_EQ(s_.level, kError);
    EXPECT_NE(s_.message.find("no transform base_link -> lidar_c"), std::string::npos) << s_.message;
    EXPECT_NE(s_.message.find("~sensor_extrinsics/lidar_c"), std::string::npos) << s_.message;
    EXPECT_FALSE(listener_.has_pose(ros::Time(now_)));
    cloud_.header.frame_id = "lidar";
    s_ = scan();
    EXPECT_NE(s_.level, kError) << s_.message;
    EXPECT_EQ(value(s_, "extrinsic"), "tf");
  }

  // 5. A burst: 30 scans at once (a bag played fast, a driver flushing its queue). The node does not fall behind: it
  //    keeps the newest waiting scan (older ones count as skipped, or the subscriber queue drops them) and answers
  //    the last one: with a pose, or, where the burst's odometry is still on its way after tf_timeout (a loaded
  //    machine), with the odometry error; either way it goes on.
  void burst() {
    const std::size_t before_burst = count(s_, "processed_scans");
    for (int i = 0; i < 30; ++i) {
      now_ += 0.01;
      odometry(now_ - 0.005, 0.0);
      imu_sample(now_ - 0.005, 9.81);
      cloud_.header.stamp = ros::Time(now_);
      points_.publish(cloud_);
    }
    const auto after_burst = listener_.wait_status(ros::Time(now_), 60s);
    ASSERT_TRUE(after_burst) << "no status for the burst's last scan; see " << dir_ / "node.log";
    s_ = *after_burst;
    if (s_.level == kError) {
      EXPECT_NE(s_.message.find("no odometry on /odom at the scan"), std::string::npos) << s_.message;
    } else {
      EXPECT_TRUE(listener_.pose(ros::Time(now_)));
    }
    EXPECT_LE(count(s_, "processed_scans"), before_burst + 30);
    ASSERT_TRUE(node_->running());
    s_ = scan_until([](const auto& st) { return st.level != kError; });
    EXPECT_GT(count(s_, "processed_scans"), before_burst);
  }

  // 6. Odometry stalls while scans go on: within tf_timeout (0.2 s) of the last message the node uses it, beyond
  //    that the status says the odometry stalled and no pose is published; odometry back, the node goes on.
  void odometry_stalls() {
    s_ = scan_until([](const auto& st) { return st.level == kError; }, /*with_odometry=*/false);
    EXPECT_NE(s_.message.find("odometry stalled"), std::string::npos) << s_.message;
    EXPECT_FALSE(listener_.has_pose(ros::Time(now_)));
    s_ = scan_until([](const auto& st) { return st.level != kError; });
    EXPECT_TRUE(listener_.pose(ros::Time(now_)));
  }

  // 7. An IMU sample that arrives after the scan it precedes (late, but after the previous sample) is used, not
  //    rejected; scans without IMU samples go on.
  void late_imu_sample() {
    rejected_ = count(s_, "rejected_messages");
    imu_sample(now_ - 0.01, 9.81);
    s_ = scan();
    EXPECT_EQ(count(s_, "rejected_messages"), rejected_) << value(s_, "last_rejection");
    EXPECT_NE(s_.level, kError) << s_.message;
  }

  // 8. Time goes back 100 s (the bag played again): tf and filter restart, the node goes on from the new time.
  void time_goes_back() {
    const std::size_t processed = count(s_, "processed_scans");
    now_ -= 100.0;
    tf_static_.publish(statics_);
    s_ = scan_until([](const auto& st) { return count(st, "time_jumps") > 0 && st.level != 2; });
    EXPECT_EQ(count(s_, "time_jumps"), 1u);
    EXPECT_NE(s_.message, "converged") << "the first scan after time went back claims convergence";
    EXPECT_GT(count(s_, "processed_scans"), processed);
    EXPECT_TRUE(node_->running());
  }

 private:
  void odometry(double t, double x) {
    nav_msgs::Odometry m;
    m.header.stamp = ros::Time(t);
    m.header.frame_id = "odom";
    m.child_frame_id = "base_link";
    m.pose.pose.position.x = x;
    m.pose.pose.orientation.w = 1.0;
    odom_.publish(m);
  }

  void imu_sample(double t, double az) {
    sensor_msgs::Imu m;
    m.header.stamp = ros::Time(t);
    m.header.frame_id = "lidar";
    m.orientation_covariance[0] = -1.0;
    m.linear_acceleration.z = az;
    imu_.publish(m);
  }

  // One scan 0.1 s after the last, with odometry (unless told not to) and an IMU sample before it; the node's status
  // on it.
  diagnostic_msgs::DiagnosticStatus scan(bool with_odometry = true) {
    now_ += 0.1;
    if (with_odometry) odometry(now_ - 0.05, 0.0);
    imu_sample(now_ - 0.05, 9.81);
    cloud_.header.stamp = ros::Time(now_);
    points_.publish(cloud_);
    const auto s = listener_.wait_status(ros::Time(now_), 60s);
    if (!s) {
      ADD_FAILURE() << "no status for the scan at " << now_ << "; see " << dir_ / "node.log";
      return {};
    }
    return *s;
  }

  // Scans until `done` holds for a status (messages on other topics may reach the node a scan later).
  template <typename Done>
  diagnostic_msgs::DiagnosticStatus scan_until(Done done, bool with_odometry = true) {
    diagnostic_msgs::DiagnosticStatus s;
    for (int i = 0; i < 30; ++i) {
      s = scan(with_odometry);
      if (::testing::Test::HasFailure() || done(s)) return s;
    }
    ADD_FAILURE() << "30 scans without the expected status; last: " << s.message;
    return s;
  }

  // Scans until the node has counted one more rejected message, for `reason`. The node must still run after it (an
  // EXPECT, not an ASSERT: the test goes on to the next message, as it always has).
  void expect_rejected(const std::string& what, const std::string& reason) {
    s_ = scan_until([&](const auto& st) {
      return count(st, "rejected_messages") > rejected_ &&
             value(st, "last_rejection").find(reason) != std::string::npos;
    });
    EXPECT_NE(value(s_, "last_rejection").find(reason), std::string::npos)
        << what << ": " << value(s_, "last_rejection");
    rejected_ = count(s_, "rejected_messages");
    EXPECT_TRUE(node_->running()) << what << " ended the node; see " << dir_ / "node.log";
  }

  fs::path dir_;
  ros::NodeHandle nh_;
  Listener listener_;
  ros::Publisher points_, odom_, imu_, tf_, tf_static_, initial_pose_;
  ros::AsyncSpinner spinner_;
  std::optional<Child> node_;  // started once the spinner runs
  sensor_msgs::PointCloud2 cloud_;
  double now_ = 1000.0;
  diagnostic_msgs::DiagnosticStatus s_;  // the node's status on the last scan
  tf2_msgs::TFMessage statics_;          // base_link -> lidar, once step 2 has sent it
  std::size_t rejected_ = 0;             // rejected messages the node has counted so far
};

TEST(RosNode, SurvivesHostileMessagesAndRefusesBadStarts) {
  const fs::path dir = fs::temp_directory_path() / ("tsdf_mcl_ros_hostile_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "cli.log";
  // A small map: 6 m of the office's test route.
  run_cli("simulate --scene office --lidar vlp16 --route test --seed 2 --length 6 -o '" + (dir / "run").string() + "'",
          log);
  run_cli("build-map --dataset '" + (dir / "run").string() + "' -o '" + (dir / "map.tsdf").string() + "'", log);
  if (HasFatalFailure()) return;
  const std::string map = "_map_file:=" + (dir / "map.tsdf").string();

  Master rosmaster(dir);
  ASSERT_TRUE(rosmaster.up()) << "rosmaster did not start; see " << dir / "rosmaster.log";
  ros::start();
  expect_bad_starts_refused(dir, map);

  HostileSession session(dir, map);
  session.wait_until_up();
  if (HasFatalFailure()) return;
  session.missing_extrinsic();
  session.extrinsic_appears();
  if (HasFatalFailure()) return;
  session.hostile_messages();
  if (HasFatalFailure()) return;
  session.frame_changes();
  session.burst();
  if (HasFatalFailure()) return;
  session.odometry_stalls();
  session.late_imu_sample();
  session.time_goes_back();
  session.node().stop();
  rosmaster.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace tsdf_mcl::ros_node
