#include "hostile_scenario.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "scenario.hpp"

namespace tsdf_mcl::node::test {
namespace {

using namespace std::chrono_literals;
constexpr auto kError = DiagnosticOut::kError;

TransformMsg transform(const std::string& parent, const std::string& child, const RawStamp& t, double x) {
  TransformMsg m;
  m.header = {t, parent};
  m.child_frame_id = child;
  m.transform.position = {x, 0.0, x == 0.0 ? 0.5 : 0.0};
  return m;
}

class HostileRun {
 public:
  HostileRun(NodeLink& link, const HostileOptions& options) : link_(link), options_(options) {
    // A ring of wall points 3 m around the sensor: enough for the filter to run (the pose does not matter here).
    for (int i = 0; i < 720; ++i) {
      const float a = static_cast<float>(i) * 0.0087266f;
      ring_.points.emplace_back(3.0f * std::cos(a), 3.0f * std::sin(a), static_cast<float>(i % 8) * 0.2f - 0.6f);
    }
  }

  // 1. No base_link -> lidar anywhere: one actionable error per scan, nothing invented.
  void missing_extrinsic() {
    odometry(now_, 0.0);
    h_ = scan();
    EXPECT_EQ(h_.status.level, kError);
    EXPECT_NE(h_.status.message.find("no transform base_link -> lidar"), std::string::npos) << h_.status.message;
    EXPECT_NE(h_.status.message.find("static_transform_publisher"), std::string::npos) << h_.status.message;
    EXPECT_EQ(h_.status.message.find('\n'), std::string::npos);
    EXPECT_FALSE(h_.pose);
  }

  // 2. The extrinsic appears (latched, as a robot_state_publisher started late sends it): the node recovers.
  void extrinsic_appears() {
    statics_ = {transform("base_link", "lidar", raw(now_), 0.0)};
    link_.tf(statics_, true);
    h_ = scan_until([](const Heard& h) { return h.count("processed_scans") > 0; });
    EXPECT_NE(h_.status.level, kError) << h_.status.message;
    ASSERT_TRUE(h_.pose);
  }

  // 3. Hostile messages: each rejected and counted, the node keeps going.
  void hostile_messages() {
    rejected_ = h_.count("rejected_messages");
    imu(now_ + 0.02, 9.81);
    imu(now_ - 0.5, 9.81);  // older than the last sample
    expect_rejected("IMU out of order", "not after the previous sample");
    imu(now_ + 0.02, std::numeric_limits<double>::quiet_NaN());
    expect_rejected("NaN IMU", "not finite");
    if (options_.ros1_time) {
      // ROS 1 time runs to 2^32 s: a transform stamped past 2^31 s is taken, not rejected.
      link_.tf({transform("odom", "base_link", {4294967290LL, 0}, 1.0)}, false);
      h_ = scan();
      EXPECT_EQ(h_.count("rejected_messages"), rejected_) << h_.value("last_rejection");
    } else {
      OdometryMsg m;
      m.header = {{-5, 0}, "odom"};
      link_.odometry(m);
      expect_rejected("odometry at -5 s", "odometry on " + options_.odom_topic + ": negative stamp (-5 s)");
    }
    odometry(now_ + 0.02, std::numeric_limits<double>::quiet_NaN());
    expect_rejected("NaN odometry", "non-finite pose");
    struct BadPose {
      Eigen::Vector3d position;
      Eigen::Vector4d quaternion;
      std::string reason;
    };
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    const std::vector<BadPose> bad = {
        {{nan, 0, 0}, {0, 0, 0, 1}, "/initialpose: non-finite pose"},
        {{inf, 0, 0}, {0, 0, 0, 1}, "/initialpose: non-finite pose"},
        {{1e300, 0, 0}, {0, 0, 0, 1}, "/initialpose: position (1e+300, 0, 0) m beyond"},
        {{9.9e5, -9.9e5, 0}, {0, 0, 0, 1}, "lies outside the map"},
        {{0, 0, 0}, {1e200, 1e200, 0, 1e200}, "is not of unit length (norm 1.73205e+200)"},
    };
    for (const BadPose& b : bad) {
      InitialPoseMsg m;
      m.header.frame_id = "map";
      m.pose.position = b.position;
      m.pose.orientation = b.quaternion;
      link_.initial_pose(m);
      expect_rejected("/initialpose " + b.reason, b.reason);
    }
    EXPECT_EQ(h_.count("initial_poses"), 0u) << "a refused /initialpose was applied";
    ASSERT_TRUE(h_.pose) << "no pose for the last scan";
    EXPECT_TRUE(h_.pose->pose.matrix().allFinite());
  }

  // 4. The cloud's frame changes to one tf does not know: sensor_extrinsics gives its mounting. A frame neither knows
  //    is the ERROR of step 1, naming the parameter as a fix too; back in the first frame, tf serves again.
  void frame_changes() {
    frame_ = "lidar_b";
    h_ = scan();
    EXPECT_NE(h_.status.level, kError) << h_.status.message;
    EXPECT_EQ(h_.value("extrinsic"), options_.extrinsic_parameter);
    EXPECT_TRUE(h_.pose);
    frame_ = "lidar_c";
    h_ = scan();
    EXPECT_EQ(h_.status.level, kError);
    EXPECT_NE(h_.status.message.find("no transform base_link -> lidar_c"), std::string::npos) << h_.status.message;
    const std::string parameter_c =
        options_.extrinsic_parameter.substr(0, options_.extrinsic_parameter.size() - 1) + "c";
    EXPECT_NE(h_.status.message.find(parameter_c), std::string::npos) << h_.status.message;
    EXPECT_FALSE(h_.pose);
    frame_ = "lidar";
    h_ = scan();
    EXPECT_NE(h_.status.level, kError) << h_.status.message;
    EXPECT_EQ(h_.value("extrinsic"), "tf");
  }

  // 5. A burst: 30 scans at once (a bag played fast, a driver flushing its queue). The node does not fall behind: it
  //    keeps the newest waiting scan (older ones count as skipped, or the subscriber queue drops them) and answers
  //    the last one: with a pose, or, where the burst's odometry is still on its way after tf_timeout (a loaded
  //    machine), with the odometry error; either way it goes on.
  void burst() {
    const std::size_t before_burst = h_.count("processed_scans");
    for (int i = 0; i < 30; ++i) {
      now_ += 0.01;
      odometry(now_ - 0.005, 0.0);
      imu(now_ - 0.005, 9.81);
      link_.cloud(ring_, raw(now_), frame_);
    }
    const auto after_burst = link_.heard(raw(now_), 60s);
    ASSERT_TRUE(after_burst) << "no status for the burst's last scan";
    h_ = *after_burst;
    if (h_.status.level == kError) {
      EXPECT_NE(h_.status.message.find("no odometry on " + options_.odom_topic + " at the scan"), std::string::npos)
          << h_.status.message;
    } else {
      EXPECT_TRUE(h_.pose);
    }
    EXPECT_LE(h_.count("processed_scans"), before_burst + 30);
    ASSERT_TRUE(link_.alive());
    h_ = scan_until([](const Heard& h) { return h.status.level != kError; });
    EXPECT_GT(h_.count("processed_scans"), before_burst);
  }

  // 6. Odometry stalls while scans go on: within tf_timeout (0.2 s) of the last message the node uses it, beyond
  //    that the status says the odometry stalled and no pose is published; odometry back, the node goes on.
  void odometry_stalls() {
    h_ = scan_until([](const Heard& h) { return h.status.level == kError; }, /*with_odometry=*/false);
    EXPECT_NE(h_.status.message.find("odometry stalled"), std::string::npos) << h_.status.message;
    EXPECT_FALSE(h_.pose);
    h_ = scan_until([](const Heard& h) { return h.status.level != kError; });
    EXPECT_TRUE(h_.pose);
  }

  // 7. An IMU sample that arrives after the scan it precedes (late, but after the previous sample) is used, not
  //    rejected; scans without IMU samples go on.
  void late_imu_sample() {
    rejected_ = h_.count("rejected_messages");
    imu(now_ - 0.01, 9.81);
    h_ = scan();
    EXPECT_EQ(h_.count("rejected_messages"), rejected_) << h_.value("last_rejection");
    EXPECT_NE(h_.status.level, kError) << h_.status.message;
  }

  // 8. Time goes back 100 s (the bag played again): tf and filter restart, the node goes on from the new time.
  void time_goes_back() {
    const std::size_t processed = h_.count("processed_scans");
    now_ -= 100.0;
    link_.tf(statics_, true);
    h_ = scan_until([](const Heard& h) { return h.count("time_jumps") > 0 && h.status.level != kError; });
    EXPECT_EQ(h_.count("time_jumps"), 1u);
    EXPECT_NE(h_.status.message, "converged") << "the first scan after time went back claims convergence";
    EXPECT_GT(h_.count("processed_scans"), processed);
    EXPECT_TRUE(link_.alive());
  }

 private:
  void odometry(double t, double x) {
    OdometryMsg m;
    m.header = {raw(t), "odom"};
    m.pose.position = {x, 0.0, 0.0};
    link_.odometry(m);
  }

  void imu(double t, double az) {
    ImuMsg m;
    m.header = {raw(t), "lidar"};
    m.linear_acceleration = {0.0, 0.0, az};
    link_.imu(m);
  }

  // One scan 0.1 s after the last, with odometry (unless told not to) and an IMU sample before it; the node's answer.
  Heard scan(bool with_odometry = true) {
    now_ += 0.1;
    if (with_odometry) odometry(now_ - 0.05, 0.0);
    imu(now_ - 0.05, 9.81);
    link_.cloud(ring_, raw(now_), frame_);
    const auto h = link_.heard(raw(now_), 60s);
    if (!h) {
      ADD_FAILURE() << "no status for the scan at " << now_;
      return {};
    }
    return *h;
  }

  // Scans until `done` holds for a status (messages on other topics may reach the node a scan later).
  template <typename Done>
  Heard scan_until(Done done, bool with_odometry = true) {
    Heard h;
    for (int i = 0; i < 30; ++i) {
      h = scan(with_odometry);
      if (::testing::Test::HasFailure() || done(h)) return h;
    }
    ADD_FAILURE() << "30 scans without the expected status; last: " << h.status.message;
    return h;
  }

  // Scans until the node has counted one more rejected message, for `reason`. The node must still run after it.
  void expect_rejected(const std::string& what, const std::string& reason) {
    h_ = scan_until([&](const Heard& h) {
      return h.count("rejected_messages") > rejected_ && h.value("last_rejection").find(reason) != std::string::npos;
    });
    EXPECT_NE(h_.value("last_rejection").find(reason), std::string::npos) << what << ": " << h_.value("last_rejection");
    rejected_ = h_.count("rejected_messages");
    EXPECT_TRUE(link_.alive()) << what << " ended the node";
  }

  NodeLink& link_;
  HostileOptions options_;
  PointCloud ring_;
  std::string frame_ = "lidar";
  double now_ = 1000.0;
  Heard h_;                            // the node's answer to the last scan
  std::vector<TransformMsg> statics_;  // base_link -> lidar, once step 2 has sent it
  std::size_t rejected_ = 0;           // rejected messages the node has counted so far
};

}  // namespace

void run_hostile_scenario(NodeLink& link, const HostileOptions& options) {
  HostileRun run(link, options);
  run.missing_extrinsic();
  run.extrinsic_appears();
  if (::testing::Test::HasFatalFailure()) return;
  run.hostile_messages();
  if (::testing::Test::HasFatalFailure()) return;
  run.frame_changes();
  run.burst();
  if (::testing::Test::HasFatalFailure()) return;
  run.odometry_stalls();
  run.late_imu_sample();
  run.time_goes_back();
}

}  // namespace tsdf_mcl::node::test
