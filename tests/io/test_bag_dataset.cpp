// ROS 1 bags as datasets (Dataset::open_bag) on bags built here with rosbag_storage and the ROS message classes:
// the decoders against roscpp's serialization, tf interpolation and extrinsic composition, and the errors.
#include <gtest/gtest.h>

#if TSDF_MCL_HAVE_ROSBAG

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "error_message.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros1_messages.hpp"

namespace tsdf_mcl {
namespace {

using test::TempDir;

template <typename M>
std::vector<std::uint8_t> serialize(const M& m) {
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(m));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, m);
  return bytes;
}

geometry_msgs::Transform transform_of(const Pose& p) {
  geometry_msgs::Transform t;
  t.translation.x = p.translation().x();
  t.translation.y = p.translation().y();
  t.translation.z = p.translation().z();
  const Eigen::Quaterniond q(p.linear());
  t.rotation.x = q.x();
  t.rotation.y = q.y();
  t.rotation.z = q.z();
  t.rotation.w = q.w();
  return t;
}

geometry_msgs::Pose pose_of(const Pose& p) {
  const geometry_msgs::Transform t = transform_of(p);
  geometry_msgs::Pose out;
  out.position.x = t.translation.x;
  out.position.y = t.translation.y;
  out.position.z = t.translation.z;
  out.orientation = t.rotation;
  return out;
}

tf2_msgs::TFMessage tf_of(const std::string& parent, const std::string& child, double t, const Pose& p) {
  tf2_msgs::TFMessage m;
  geometry_msgs::TransformStamped s;
  s.header.stamp = ros::Time(t);
  s.header.frame_id = parent;
  s.child_frame_id = child;
  s.transform = transform_of(p);
  m.transforms.push_back(s);
  return m;
}

// A cloud of `n` points: point k at (k + 1, t, 0.5) in `frame`, plus one NaN point.
sensor_msgs::PointCloud2 cloud_of(double t, const std::string& frame, int n = 3) {
  PointCloud c;
  for (int k = 0; k < n; ++k) c.points.emplace_back(static_cast<float>(k + 1), static_cast<float>(t), 0.5f);
  c.points.emplace_back(std::nanf(""), 0.0f, 0.0f);
  c.intensity.assign(c.points.size(), 0.25f);
  const EncodedPointCloud2 e = encode_pointcloud2(c);
  sensor_msgs::PointCloud2 m;
  m.header.stamp = ros::Time(t);
  m.header.frame_id = frame;
  m.height = 1;
  m.width = e.layout.width;
  for (const PointField& f : e.layout.fields) {
    sensor_msgs::PointField pf;
    pf.name = f.name;
    pf.offset = f.offset;
    pf.datatype = f.datatype;
    pf.count = f.count;
    m.fields.push_back(pf);
  }
  m.point_step = e.layout.point_step;
  m.row_step = e.layout.row_step;
  m.data = e.data;
  m.is_dense = false;
  return m;
}

void expect_near(const Pose& a, const Pose& b, double tolerance = 1e-9) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << a.matrix() << "\n" << b.matrix();
}

using test::error_of;

// ---------------------------------------------------------------------- the decoders against roscpp

TEST(BagMessages, DecodersAgreeWithRoscpp) {
  const sensor_msgs::PointCloud2 cloud = cloud_of(12.5, "velodyne");
  const std::vector<std::uint8_t> cloud_bytes = serialize(cloud);
  const ros1::PointCloud2Message m = ros1::decode_pointcloud2_message(cloud_bytes.data(), cloud_bytes.size(), "pc2");
  EXPECT_EQ(m.header.frame_id, "velodyne");
  EXPECT_EQ(m.header.stamp(), 12.5);
  EXPECT_EQ(m.layout.width, cloud.width);
  EXPECT_EQ(m.layout.fields.size(), cloud.fields.size());
  EXPECT_EQ(
      std::vector<std::uint8_t>(cloud_bytes.begin() + m.data_offset, cloud_bytes.begin() + m.data_offset + m.data_size),
      cloud.data);
  // Our encoder writes what roscpp writes.
  ros1::Header h;
  h.sec = cloud.header.stamp.sec;
  h.nsec = cloud.header.stamp.nsec;
  h.frame_id = "velodyne";
  EXPECT_EQ(ros1::encode_pointcloud2_message(h, m.layout, cloud.data), cloud_bytes);

  const Pose p = pose_from_xyz_rpy(1, -2, 3, 0.1, -0.2, 2.5);
  tf2_msgs::TFMessage tf = tf_of("odom", "base_link", 3.25, p);
  tf.transforms.push_back(tf.transforms[0]);
  tf.transforms[1].child_frame_id = "wheel";
  const std::vector<std::uint8_t> tf_bytes = serialize(tf);
  const std::vector<ros1::TransformStamped> transforms =
      ros1::decode_tf_message(tf_bytes.data(), tf_bytes.size(), "tf");
  ASSERT_EQ(transforms.size(), 2u);
  EXPECT_EQ(transforms[1].child_frame_id, "wheel");
  EXPECT_EQ(transforms[0].header.frame_id, "odom");
  expect_near(transforms[0].transform, p, 1e-12);

  nav_msgs::Odometry odom;
  odom.header.frame_id = "odom";
  odom.header.stamp = ros::Time(7, 5);
  odom.child_frame_id = "base_link";
  odom.pose.pose = pose_of(p);
  odom.twist.twist.linear.x = 1.0;
  const std::vector<std::uint8_t> odom_bytes = serialize(odom);
  const ros1::PoseMessage o = ros1::decode_odometry(odom_bytes.data(), odom_bytes.size(), "odom");
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.header.nsec, 5u);
  expect_near(o.pose, p, 1e-12);

  geometry_msgs::PoseStamped ps;
  ps.header.frame_id = "map";
  ps.pose = pose_of(p);
  const std::vector<std::uint8_t> ps_bytes = serialize(ps);
  expect_near(ros1::decode_pose_stamped(ps_bytes.data(), ps_bytes.size(), "ps").pose, p, 1e-12);
  geometry_msgs::PoseWithCovarianceStamped pwcs;
  pwcs.header.frame_id = "map";
  pwcs.pose.pose = pose_of(p);
  pwcs.pose.covariance[7] = 0.25;
  const std::vector<std::uint8_t> pwcs_bytes = serialize(pwcs);
  expect_near(ros1::decode_pose_with_covariance_stamped(pwcs_bytes.data(), pwcs_bytes.size(), "pwcs").pose, p, 1e-12);

  sensor_msgs::Imu imu;
  imu.header.frame_id = "imu_link";
  imu.linear_acceleration.x = 0.1;
  imu.linear_acceleration.z = 9.8;
  imu.angular_velocity.y = -0.5;
  const std::vector<std::uint8_t> imu_bytes = serialize(imu);
  const ros1::Imu i = ros1::decode_imu(imu_bytes.data(), imu_bytes.size(), "imu");
  EXPECT_EQ(i.linear_acceleration, Eigen::Vector3d(0.1, 0, 9.8));
  EXPECT_EQ(i.angular_velocity, Eigen::Vector3d(0, -0.5, 0));
  // The MD5 sums we check topics against are the message classes'.
  EXPECT_STREQ(ros1::kPointCloud2.md5, ros::message_traits::MD5Sum<sensor_msgs::PointCloud2>::value());
  EXPECT_STREQ(ros1::kTfMessage.md5, ros::message_traits::MD5Sum<tf2_msgs::TFMessage>::value());
  EXPECT_STREQ(ros1::kOdometry.md5, ros::message_traits::MD5Sum<nav_msgs::Odometry>::value());
  EXPECT_STREQ(ros1::kPoseStamped.md5, ros::message_traits::MD5Sum<geometry_msgs::PoseStamped>::value());
  EXPECT_STREQ(ros1::kPoseWithCovarianceStamped.md5,
               ros::message_traits::MD5Sum<geometry_msgs::PoseWithCovarianceStamped>::value());
  EXPECT_STREQ(ros1::kImu.md5, ros::message_traits::MD5Sum<sensor_msgs::Imu>::value());

  // A zero quaternion (an unset pose) is not a rotation.
  ps.pose.orientation.w = 0.0;
  const std::vector<std::uint8_t> zero = serialize(ps);
  EXPECT_NE(error_of([&] { ros1::decode_pose_stamped(zero.data(), zero.size(), "ps"); }).find("not a unit quaternion"),
            std::string::npos);
}

// ----------------------------------------------------------------------------------- a robot's bag

// The robot: odom -> base_footprint moving (tf at 10 Hz from 1.0 s), base_footprint -> base_link -> os_sensor ->
// os_lidar static, an IMU in imu_link; scans at 20 Hz from 0.925 s in os_lidar; ground truth as PoseStamped of
// base_link at 4 Hz; odometry also on /odom.
const Pose kFootprintToBase = pose_from_xyz_rpy(0.05, 0, 0.12, 0, 0, 0);
const Pose kBaseToSensor = pose_from_xyz_rpy(0.2, -0.1, 0.6, 0.02, -0.05, 0.3);
const Pose kSensorToLidar = pose_from_xyz_rpy(0, 0, 0.036, 0, 0, M_PI);
const Pose kLidarToImu = pose_from_xyz_rpy(0.01, 0.0, -0.02, 0, 0, M_PI / 2);

Pose odom_T_footprint(double t) { return pose_from_xyz_rpy(0.5 * t, 0.1 * t * t, 0, 0, 0, 0.2 * t); }
Pose world_T_base(double t) { return pose_from_xyz_rpy(10 + t, 5 - 0.3 * t, 0.12, 0, 0, 1.0 + 0.1 * t); }
double scan_time(int k) { return 0.925 + 0.05 * k; }

struct RobotBag {
  TempDir dir;
  std::filesystem::path file;
  // `statics_at`: when /tf_static is recorded and stamped (a recording started after the static publisher holds
  // the latched message at the time it subscribed, after the first scans).
  RobotBag(int scans = 30, bool out_of_order = false, bool extrinsic = true, double statics_at = 0.5,
           const Pose& base_to_sensor = kBaseToSensor) {
    file = dir / "robot.bag";
    rosbag::Bag bag(file.string(), rosbag::bagmode::Write);
    tf2_msgs::TFMessage statics = tf_of("base_footprint", "base_link", statics_at, kFootprintToBase);
    if (extrinsic) {
      statics.transforms.push_back(tf_of("base_link", "os_sensor", statics_at, base_to_sensor).transforms[0]);
      statics.transforms.push_back(tf_of("os_sensor", "os_lidar", statics_at, kSensorToLidar).transforms[0]);
    }
    statics.transforms.push_back(tf_of("os_lidar", "imu_link", statics_at, kLidarToImu).transforms[0]);
    bag.write("/tf_static", ros::Time(statics_at), statics);
    for (int k = 0; k <= 40; ++k) {
      const double t = 1.0 + 0.1 * k;
      bag.write("/tf", ros::Time(t), tf_of("odom", "base_footprint", t, odom_T_footprint(t)));
      nav_msgs::Odometry odom;
      odom.header.stamp = ros::Time(t);
      odom.header.frame_id = "odom";
      odom.child_frame_id = "base_footprint";
      odom.pose.pose = pose_of(odom_T_footprint(t));
      bag.write("/odom", ros::Time(t), odom);
    }
    for (int k = 0; k <= 20; ++k) {
      const double t = 0.8 + 0.25 * k;
      geometry_msgs::PoseStamped gt;
      gt.header.stamp = ros::Time(t);
      gt.header.frame_id = "map";
      gt.pose = pose_of(world_T_base(t));
      bag.write("/vicon/robot", ros::Time(t), gt);
    }
    for (int k = 0; k < 200; ++k) {
      const double t = 0.9 + 0.01 * k;
      sensor_msgs::Imu imu;
      imu.header.stamp = ros::Time(t);
      imu.header.frame_id = "imu_link";
      imu.linear_acceleration.x = 0.3;
      imu.linear_acceleration.y = -0.1;
      imu.linear_acceleration.z = 9.8;
      bag.write("/imu/data", ros::Time(t), imu);
    }
    for (int k = 0; k < scans; ++k) {
      double t = scan_time(k);
      if (out_of_order && k == 7) t = scan_time(5);
      bag.write("/os_cloud_node/points", ros::Time(scan_time(k) + 0.01), cloud_of(t, "os_lidar"));
    }
    std_msgs::String note;
    note.data = "not a cloud";
    bag.write("/notes", ros::Time(1.0), note);
    bag.write("/velodyne_points", ros::Time(1.0), cloud_of(1.0, "velodyne"));
    bag.close();
  }
};

const RobotBag& robot_bag() {
  static const RobotBag bag;
  return bag;
}

BagOptions robot_options() {
  BagOptions o;
  o.points_topic = "/os_cloud_node/points";
  o.odom_frame = "odom";
  o.base_frame = "base_link";
  o.ground_truth_topic = "/vicon/robot";
  o.imu_topic = "imu/data";  // without the leading '/'
  return o;
}

TEST(BagDataset, TfInterpolationAndExtrinsicComposition) {
  const Dataset ds = Dataset::open_bag(robot_bag().file, robot_options());
  EXPECT_TRUE(ds.is_bag());
  // Scans from 0.925 s; tf from 1.0 s: the first two scans have no odometry and are left out.
  ASSERT_EQ(ds.size(), 28u);
  EXPECT_NE(ds.summary().find("left out 2 scans before and 0 after"), std::string::npos) << ds.summary();
  EXPECT_DOUBLE_EQ(ds.time(0), scan_time(2));
  ASSERT_TRUE(ds.has_odometry());
  ASSERT_TRUE(ds.has_poses());
  const Pose base_T_lidar = kBaseToSensor * kSensorToLidar;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const double t = ds.time(i);
    // tf odom -> base_footprint, interpolated between its 10 Hz samples.
    const double t0 = 1.0 + 0.1 * std::floor((t - 1.0) / 0.1 + 1e-9), t1 = t0 + 0.1;
    const double f = (t - t0) / (t1 - t0);
    const Pose a = odom_T_footprint(t0), b = odom_T_footprint(std::min(t1, 5.0));
    Pose odom_T_fp = Pose::Identity();
    odom_T_fp.linear() = Eigen::Quaterniond(a.linear()).slerp(f, Eigen::Quaterniond(b.linear())).toRotationMatrix();
    odom_T_fp.translation() = (1 - f) * a.translation() + f * b.translation();
    expect_near(ds.odometry(i), odom_T_fp * kFootprintToBase * base_T_lidar);
    // Ground truth of base_link at 4 Hz, composed with base_link -> os_lidar.
    const double g0 = 0.8 + 0.25 * std::floor((t - 0.8) / 0.25 + 1e-9);
    const double g = (t - g0) / 0.25;
    const Pose ga = world_T_base(g0), gb = world_T_base(g0 + 0.25);
    Pose w_T_b = Pose::Identity();
    w_T_b.linear() = Eigen::Quaterniond(ga.linear()).slerp(g, Eigen::Quaterniond(gb.linear())).toRotationMatrix();
    w_T_b.translation() = (1 - g) * ga.translation() + g * gb.translation();
    expect_near(ds.pose(i), w_T_b * base_T_lidar);
  }
  // Scans load lazily, NaN dropped and counted.
  std::size_t dropped = 0;
  const PointCloud c = ds.load_scan(3, &dropped);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(dropped, 1u);
  EXPECT_FLOAT_EQ(c.points[1].y(), static_cast<float>(ds.time(3)));
  EXPECT_EQ(c.intensity, std::vector<float>(3, 0.25f));
  EXPECT_EQ(ds.scan_path(3).string(), robot_bag().file.string() + ":/os_cloud_node/points[3]");
  // IMU: specific force in imu_link, rotated into os_lidar (yaw +90 deg: x -> y).
  const std::vector<ImuSample> imu = ds.imu();
  ASSERT_EQ(imu.size(), 200u);
  EXPECT_LT((imu[0].acceleration - Eigen::Vector3d(0.1, 0.3, 9.8)).norm(), 1e-9) << imu[0].acceleration.transpose();
  ASSERT_TRUE(imu_up_at(imu, ds.time(0)).has_value());
}

TEST(BagDataset, LatchedStaticTransformsRecordedMidStreamHoldFromTheStart) {
  // /tf_static recorded (and stamped) at 3.0 s, after the last scan: it still places every scan.
  const RobotBag late(30, false, true, 3.0);
  const Dataset ds = Dataset::open_bag(late.file, robot_options());
  const Dataset reference = Dataset::open_bag(robot_bag().file, robot_options());
  ASSERT_EQ(ds.size(), reference.size());
  for (std::size_t i = 0; i < ds.size(); ++i) {
    expect_near(ds.odometry(i), reference.odometry(i));
    expect_near(ds.pose(i), reference.pose(i));
  }
  EXPECT_EQ(ds.imu().size(), reference.imu().size());
}

TEST(BagDataset, OdometryFromATopic) {
  BagOptions o = robot_options();
  o.odom_topic = "/odom";
  o.ground_truth_topic.clear();
  o.imu_topic.clear();
  const Dataset from_topic = Dataset::open_bag(robot_bag().file, o);
  const Dataset from_tf = Dataset::open_bag(robot_bag().file, robot_options());
  ASSERT_EQ(from_topic.size(), from_tf.size());
  EXPECT_FALSE(from_topic.has_poses());
  EXPECT_NE(from_topic.missing_poses().find("no ground truth"), std::string::npos);
  EXPECT_TRUE(from_topic.imu().empty());
  for (std::size_t i = 0; i < from_tf.size(); ++i) expect_near(from_topic.odometry(i), from_tf.odometry(i));
}

TEST(BagDataset, WithoutOdometry) {
  BagOptions o = robot_options();
  o.odom_frame = "wheel_odom";  // not in tf
  o.ground_truth_topic.clear();
  const Dataset ds = Dataset::open_bag(robot_bag().file, o);
  EXPECT_EQ(ds.size(), 30u);  // nothing to cover: every scan
  EXPECT_FALSE(ds.has_odometry());
  EXPECT_NE(ds.missing_odometry().find("no tf frame 'wheel_odom' (--odom_frame) and no --odom_topic"),
            std::string::npos)
      << ds.missing_odometry();
}

TEST(BagDataset, ClearErrors) {
  const std::filesystem::path& file = robot_bag().file;
  TempDir dir;
  const auto open = [&](const std::filesystem::path& f, const BagOptions& o) {
    return error_of([&] { Dataset::open_bag(f, o); });
  };
  BagOptions o = robot_options();
  o.points_topic = "/points";
  EXPECT_NE(open(file, o).find("has no topic /points (the points topic); its sensor_msgs/PointCloud2 topics: "
                               "/os_cloud_node/points, /velodyne_points"),
            std::string::npos)
      << open(file, o);
  o.points_topic = "/notes";
  EXPECT_NE(open(file, o).find("topic /notes (the points topic) carries std_msgs/String, not sensor_msgs/PointCloud2"),
            std::string::npos)
      << open(file, o);
  o = robot_options();
  o.ground_truth_topic = "/imu/data";
  EXPECT_NE(open(file, o).find("carries sensor_msgs/Imu, not nav_msgs/Odometry or geometry_msgs/PoseStamped"),
            std::string::npos);
  o = robot_options();
  o.base_frame = "chassis";
  EXPECT_NE(open(file, o).find("no tf connects 'odom' and 'chassis' ('chassis' is in no tf message)"),
            std::string::npos)
      << open(file, o);

  // The LiDAR's mounting missing from /tf_static: the message names both frames.
  const RobotBag no_static(10, false, /*extrinsic=*/false);
  const std::string missing = open(no_static.file, robot_options());
  EXPECT_NE(missing.find("no tf connects 'base_link' and 'os_lidar'"), std::string::npos) << missing;

  // An extrinsic of 1e300 m gave a trajectory of -nan lines with exit status 0 (localize --bag).
  const RobotBag absurd(10, false, true, 0.5, pose_from_xyz_rpy(1e300, 0, 0, 0, 0, 0));
  const std::string far = open(absurd.file, robot_options());
  EXPECT_NE(far.find("/tf_static message 0: tf 'base_link' -> 'os_sensor': translation (1e+300, 0, 0) m is not "
                     "finite or beyond 1e+06 m"),
            std::string::npos)
      << far;

  const RobotBag disordered(10, /*out_of_order=*/true);
  EXPECT_NE(open(disordered.file, robot_options())
                .find("scans out of order on /os_cloud_node/points: scan 7 is stamped 1.175 s"),
            std::string::npos)
      << open(disordered.file, robot_options());

  // Not bags; rosbag2 files that are not what they seem.
  test::write_bytes(dir / "text.bag", "hello, I am not a bag\n");
  EXPECT_NE(open(dir / "text.bag", o).find("is not a bag: neither a ROS 1 bag"), std::string::npos);
  test::write_bytes(dir / "empty.bag", "");
  EXPECT_NE(open(dir / "empty.bag", o).find("is not a bag"), std::string::npos);
  test::write_bytes(dir / "ros2.db3", std::string("SQLite format 3\0", 16) + std::string(100, 'x'));
  EXPECT_NE(open(dir / "ros2.db3", o).find("ros2.db3"), std::string::npos) << open(dir / "ros2.db3", o);
  std::filesystem::create_directories(dir / "rosbag2_run");
  test::write_bytes(dir / "rosbag2_run" / "metadata.yaml", "rosbag2_bagfile_information: {}\n");
  EXPECT_NE(open(dir / "rosbag2_run", o).find("no relative_file_paths"), std::string::npos);
  EXPECT_NE(open(dir / "missing.bag", o).find("does not exist"), std::string::npos) << open(dir / "missing.bag", o);

  // Truncated bags: cut at several places, every one a single sentence naming the file.
  const std::string bytes = test::read_bytes(file);
  for (const double fraction : {0.002, 0.3, 0.5, 0.9, 0.999}) {
    const auto cut = dir / "cut.bag";
    test::write_bytes(cut, bytes.substr(0, static_cast<std::size_t>(fraction * static_cast<double>(bytes.size()))));
    const std::string e = open(cut, robot_options());
    EXPECT_NE(e.find(cut.string()), std::string::npos) << fraction << ": " << e;
    EXPECT_TRUE(e.find("truncated") != std::string::npos || e.find("corrupt") != std::string::npos ||
                e.find("not indexed") != std::string::npos)
        << fraction << ": " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
}

// Bit flips inside a bag: each ends in a dataset or one Error, never a crash of this process.
TEST(BagDataset, CorruptBytesNeverCrash) {
  const std::string bytes = test::read_bytes(robot_bag().file);
  TempDir dir;
  std::uint64_t state = 12345;
  for (int trial = 0; trial < 12; ++trial) {
    std::string corrupt = bytes;
    for (int flips = 0; flips < 8; ++flips) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      corrupt[4096 + (state >> 33) % (corrupt.size() - 4096)] ^= static_cast<char>(1 + (state >> 13) % 255);
    }
    const auto file = dir / ("corrupt" + std::to_string(trial) + ".bag");
    test::write_bytes(file, corrupt);
    try {
      const Dataset ds = Dataset::open_bag(file, robot_options());
      for (std::size_t i = 0; i < ds.size(); ++i) ds.load_scan(i);
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace tsdf_mcl

#else

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/dataset.hpp"

TEST(BagDataset, BuiltWithoutBagSupport) {
  EXPECT_FALSE(tsdf_mcl::Dataset::ros1_bag_support());
  const tsdf_mcl::test::TempDir dir;
  tsdf_mcl::test::write_bytes(dir / "run.bag", "#ROSBAG V2.0\n" + std::string(5000, '\0'));
  tsdf_mcl::BagOptions o;
  o.points_topic = "/points";
  try {
    tsdf_mcl::Dataset::open_bag(dir / "run.bag", o);
    FAIL();
  } catch (const tsdf_mcl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("built without ROS 1 bag support"), std::string::npos) << e.what();
  }
}

#endif
