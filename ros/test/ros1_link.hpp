#pragma once
// The ROS 1 node as a NodeLink (node_core/test/node_link.hpp): the test's publishers and subscribers on the node's
// topics, so that the scenarios every transport shares (hostile_scenario.hpp) drive tsdf_mcl_node too. Waits are on
// what the subscribers received (a condition variable) or on connections.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/Imu.h>
#include <std_srvs/Empty.h>
#include <tf2_msgs/TFMessage.h>

#include "heard_record.hpp"
#include "message_checks.hpp"
#include "node_link.hpp"
#include "node_test_support.hpp"
#include "ros_conversions.hpp"

namespace tsdf_mcl::ros_node {

class Ros1Link : public node::test::NodeLink {
 public:
  Ros1Link(ros::NodeHandle& nh, Child& node, double transform_tolerance)
      : node_(node),
        heard_(transform_tolerance),
        points_(nh.advertise<sensor_msgs::PointCloud2>("/points", 50)),
        odom_(nh.advertise<nav_msgs::Odometry>("/odom", 100)),
        imu_(nh.advertise<sensor_msgs::Imu>("/imu", 100)),
        tf_(nh.advertise<tf2_msgs::TFMessage>("/tf", 100)),
        tf_static_(nh.advertise<tf2_msgs::TFMessage>("/tf_static", 10, true)),
        initial_pose_(nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("/initialpose", 10)),
        clock_(nh.advertise<rosgraph_msgs::Clock>("/clock", 10)) {
    subs_.push_back(nh.subscribe("/diagnostics", 100, &Ros1Link::on_status, this));
    subs_.push_back(nh.subscribe("/amcl_pose", 100, &Ros1Link::on_pose, this));
    subs_.push_back(nh.subscribe("/tf", 100, &Ros1Link::on_tf, this));
  }

  // Once the node is up: every publisher connected to it.
  bool connected(std::chrono::seconds timeout) {
    for (ros::Publisher* p : {&points_, &odom_, &imu_, &tf_, &tf_static_, &initial_pose_}) {
      if (!wait_until([&] { return p->getNumSubscribers() > 0; }, timeout)) return false;
    }
    return true;
  }

  void tf(const std::vector<node::TransformMsg>& transforms, bool is_static) override {
    tf2_msgs::TFMessage m;
    for (const node::TransformMsg& t : transforms) {
      geometry_msgs::TransformStamped s;
      s.header.stamp = stamp(t.header.stamp);
      s.header.frame_id = t.header.frame_id;
      s.child_frame_id = t.child_frame_id;
      s.transform.translation.x = t.transform.position.x();
      s.transform.translation.y = t.transform.position.y();
      s.transform.translation.z = t.transform.position.z();
      s.transform.rotation.x = t.transform.orientation[0];
      s.transform.rotation.y = t.transform.orientation[1];
      s.transform.rotation.z = t.transform.orientation[2];
      s.transform.rotation.w = t.transform.orientation[3];
      m.transforms.push_back(s);
    }
    (is_static ? tf_static_ : tf_).publish(m);
  }
  void cloud(const PointCloud& cloud, const node::RawStamp& t, const std::string& frame) override {
    node::CloudOut out;
    out.stamp = node::to_stamp(t);
    out.frame_id = frame;
    out.cloud = encode_pointcloud2(cloud);
    sensor_msgs::PointCloud2 m = msg_from_cloud(out);
    m.header.stamp = stamp(t);
    heard_.forget(node::to_stamp(t));
    points_.publish(m);
  }
  void odometry(const node::OdometryMsg& o) override {
    nav_msgs::Odometry m;
    m.header.stamp = stamp(o.header.stamp);
    m.header.frame_id = o.header.frame_id;
    m.child_frame_id = "base_link";
    m.pose.pose.position.x = o.pose.position.x();
    m.pose.pose.position.y = o.pose.position.y();
    m.pose.pose.position.z = o.pose.position.z();
    m.pose.pose.orientation.x = o.pose.orientation[0];
    m.pose.pose.orientation.y = o.pose.orientation[1];
    m.pose.pose.orientation.z = o.pose.orientation[2];
    m.pose.pose.orientation.w = o.pose.orientation[3];
    odom_.publish(m);
  }
  void imu(const node::ImuMsg& i) override {
    sensor_msgs::Imu m;
    m.header.stamp = stamp(i.header.stamp);
    m.header.frame_id = i.header.frame_id;
    m.orientation_covariance[0] = -1.0;
    m.linear_acceleration.x = i.linear_acceleration.x();
    m.linear_acceleration.y = i.linear_acceleration.y();
    m.linear_acceleration.z = i.linear_acceleration.z();
    imu_.publish(m);
  }
  void clock(const node::RawStamp& now) override {
    rosgraph_msgs::Clock m;
    m.clock = stamp(now);
    clock_.publish(m);
  }
  void initial_pose(const node::InitialPoseMsg& p) override {
    geometry_msgs::PoseWithCovarianceStamped m;
    m.header.stamp = stamp(p.header.stamp);
    m.header.frame_id = p.header.frame_id;
    m.pose.pose.position.x = p.pose.position.x();
    m.pose.pose.position.y = p.pose.position.y();
    m.pose.pose.position.z = p.pose.position.z();
    m.pose.pose.orientation.x = p.pose.orientation[0];
    m.pose.pose.orientation.y = p.pose.orientation[1];
    m.pose.pose.orientation.z = p.pose.orientation[2];
    m.pose.pose.orientation.w = p.pose.orientation[3];
    initial_pose_.publish(m);
  }
  void global_localization() override {
    std_srvs::Empty call;
    EXPECT_TRUE(ros::service::call("/global_localization", call));
  }
  std::optional<node::test::Heard> heard(const node::RawStamp& scan, std::chrono::seconds timeout) override {
    return heard_.heard(node::to_stamp(scan), timeout);
  }
  std::optional<node::TransformOut> map_odom(const node::RawStamp& scan, std::chrono::seconds timeout) override {
    return heard_.map_odom(node::to_stamp(scan), timeout);
  }
  bool alive() override { return node_.running(); }

 private:
  static ros::Time stamp(const node::RawStamp& t) { return ros::Time(static_cast<std::uint32_t>(t.sec), t.nanosec); }
  static node::Stamp stamp_of(const ros::Time& t) { return node::to_stamp(raw_stamp(t)); }

  void on_status(const diagnostic_msgs::DiagnosticArrayConstPtr& m) {
    for (const auto& s : m->status) {
      if (s.name != "tsdf_mcl: localization") continue;
      node::DiagnosticOut d;
      d.stamp = stamp_of(m->header.stamp);
      d.level = static_cast<node::DiagnosticOut::Level>(s.level);
      d.name = s.name;
      d.message = s.message;
      for (const auto& kv : s.values) d.values.emplace_back(kv.key, kv.value);
      heard_.status(d);
    }
  }
  void on_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& m) {
    node::PoseOut p;
    p.stamp = stamp_of(m->header.stamp);
    p.frame_id = m->header.frame_id;
    p.pose = node::to_pose(raw_pose(m->pose.pose));
    heard_.pose(p);
  }
  void on_tf(const tf2_msgs::TFMessageConstPtr& m) {
    for (const auto& t : m->transforms) {
      if (t.header.frame_id != "map" || t.child_frame_id != "odom") continue;
      node::TransformOut out;
      out.stamp = stamp_of(t.header.stamp);
      out.parent = t.header.frame_id;
      out.child = t.child_frame_id;
      out.pose = node::to_pose(raw_pose(t.transform));
      heard_.map_odom(out);
    }
  }

  Child& node_;
  node::test::HeardRecord heard_;
  ros::Publisher points_, odom_, imu_, tf_, tf_static_, initial_pose_, clock_;
  std::vector<ros::Subscriber> subs_;
};

}  // namespace tsdf_mcl::ros_node
