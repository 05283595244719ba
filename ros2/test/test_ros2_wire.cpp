// The wire format checked against ROS 2's definitions, not only against this project's own client: messages as
// Cyclone encodes them compared byte for byte with CDR written by hand from the published .msg layouts (cdr_bytes.hpp)
// — every type the node reads, written by the test; every type the node writes, taken from the node — and the node's
// endpoints as a ROS 2 tool discovers them: topic names, type names and QoS.
#include <dds/ddsi/ddsi_serdata.h>
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <map>

#include "cdr_bytes.hpp"
#include "dds_conversions.hpp"
#include "ros2_test_support.hpp"
#include "scenario.hpp"
#include "std_msgs.h"
#include "std_srvs.h"

namespace tsdf_mcl::ros2_node::test {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

// Header, Time, Pose: the building blocks of the layouts below, in their .msg order.
void time_of(CdrBytes& c, const builtin_interfaces_msg_dds__Time_& t) { c.i32(t.sec).u32(t.nanosec); }
void header_of(CdrBytes& c, const std_msgs_msg_dds__Header_& h) {
  time_of(c, h.stamp);
  c.string(h.frame_id);
}
void pose_of(CdrBytes& c, const geometry_msgs_msg_dds__Pose_& p) {
  c.f64(p.position.x).f64(p.position.y).f64(p.position.z);
  c.f64(p.orientation.x).f64(p.orientation.y).f64(p.orientation.z).f64(p.orientation.w);
}
void doubles(CdrBytes& c, const double* v, int n) {
  for (int i = 0; i < n; ++i) c.f64(v[i]);
}

Bytes pose_with_covariance_stamped(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& m) {
  CdrBytes c;
  header_of(c, m.header);
  pose_of(c, m.pose.pose);
  doubles(c, m.pose.covariance, 36);
  return c.message();
}

Bytes tf_message(const tf2_msgs_msg_dds__TFMessage_& m) {
  CdrBytes c;
  c.length(m.transforms._length);
  for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
    const geometry_msgs_msg_dds__TransformStamped_& t = m.transforms._buffer[i];
    header_of(c, t.header);
    c.string(t.child_frame_id);
    c.f64(t.transform.translation.x).f64(t.transform.translation.y).f64(t.transform.translation.z);
    c.f64(t.transform.rotation.x).f64(t.transform.rotation.y).f64(t.transform.rotation.z).f64(t.transform.rotation.w);
  }
  return c.message();
}

Bytes diagnostic_array(const diagnostic_msgs_msg_dds__DiagnosticArray_& m) {
  CdrBytes c;
  header_of(c, m.header);
  c.length(m.status._length);
  for (std::uint32_t i = 0; i < m.status._length; ++i) {
    const diagnostic_msgs_msg_dds__DiagnosticStatus_& s = m.status._buffer[i];
    c.u8(s.level).string(s.name).string(s.message).string(s.hardware_id).length(s.values._length);
    for (std::uint32_t k = 0; k < s.values._length; ++k)
      c.string(s.values._buffer[k].key).string(s.values._buffer[k].value);
  }
  return c.message();
}

Bytes point_cloud2(const sensor_msgs_msg_dds__PointCloud2_& m) {
  CdrBytes c;
  header_of(c, m.header);
  c.u32(m.height).u32(m.width).length(m.fields._length);
  for (std::uint32_t i = 0; i < m.fields._length; ++i) {
    const sensor_msgs_msg_dds__PointField_& f = m.fields._buffer[i];
    c.string(f.name).u32(f.offset).u8(f.datatype).u32(f.count);
  }
  c.boolean(m.is_bigendian).u32(m.point_step).u32(m.row_step).length(m.data._length);
  for (std::uint32_t i = 0; i < m.data._length; ++i) c.u8(m.data._buffer[i]);
  c.boolean(m.is_dense);
  return c.message();
}

Bytes particle_cloud(const nav2_msgs_msg_dds__ParticleCloud_& m) {
  CdrBytes c;
  header_of(c, m.header);
  c.length(m.particles._length);
  for (std::uint32_t i = 0; i < m.particles._length; ++i) {
    pose_of(c, m.particles._buffer[i].pose);
    c.f64(m.particles._buffer[i].weight);
  }
  return c.message();
}

// The message Cyclone would send for `sample`, as a reader receives it: written on `topic` by the test and taken
// back undecoded.
Bytes as_sent(dds_entity_t pp, const dds_topic_descriptor_t& type, const std::string& topic, const void* sample) {
  const Reader reader(pp, type, topic, reliable_qos(1));
  const Writer writer(pp, type, topic, reliable_qos(1));
  EXPECT_TRUE(wait_for_matched(pp, writer.handle(), 1, 60s));
  writer.write(sample);
  const dds_entity_t waitset = dds_create_waitset(pp);
  const dds_entity_t condition = dds_create_readcondition(reader.handle(), DDS_ANY_STATE);
  dds_waitset_attach(waitset, condition, 0);
  dds_waitset_wait(waitset, nullptr, 0, DDS_SECS(60));
  Bytes bytes;
  struct ddsi_serdata* data = nullptr;
  dds_sample_info_t info;
  if (dds_takecdr(reader.handle(), &data, 1, &info, DDS_ANY_STATE) == 1) {
    bytes.resize(ddsi_serdata_size(data));
    ddsi_serdata_to_ser(data, 0, bytes.size(), bytes.data());
    ddsi_serdata_unref(data);
  }
  dds_delete(condition);
  dds_delete(waitset);
  return bytes;
}

// What `reader` (of the node's topic) has received, undecoded and decoded.
struct Received {
  Bytes bytes;
  Sample sample;
};
std::optional<Received> take_raw(const Reader& reader, std::chrono::seconds timeout) {
  const dds_entity_t waitset = dds_create_waitset(dds_get_participant(reader.handle()));
  const dds_entity_t condition = dds_create_readcondition(reader.handle(), DDS_ANY_STATE);
  dds_waitset_attach(waitset, condition, 0);
  dds_waitset_wait(waitset, nullptr, 0, std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count());
  std::optional<Received> out;
  struct ddsi_serdata* data = nullptr;
  dds_sample_info_t info;
  if (dds_takecdr(reader.handle(), &data, 1, &info, DDS_ANY_STATE) == 1) {
    Received r;
    r.bytes.resize(ddsi_serdata_size(data));
    ddsi_serdata_to_ser(data, 0, r.bytes.size(), r.bytes.data());
    const dds_topic_descriptor_t* type = &reader.type();
    void* memory = dds_alloc(type->m_size);
    std::memset(memory, 0, type->m_size);
    r.sample = Sample(memory, [type](void* p) { dds_sample_free(p, type, DDS_FREE_ALL); });
    EXPECT_TRUE(ddsi_serdata_to_sample(data, memory, nullptr, nullptr));
    ddsi_serdata_unref(data);
    out = std::move(r);
  }
  dds_delete(condition);
  dds_delete(waitset);
  return out;
}

TEST(Ros2Wire, MessagesTheNodeReadsAreEncodedAsTheMsgLayoutsSay) {
  DomainClaim domain;
  const Participant participant(domain_from_environment());
  const dds_entity_t pp = participant.handle();

  std::string frame = "base_link", child = "lidar";
  geometry_msgs_msg_dds__TransformStamped_ t{{{1700000000, 123456789}, frame.data()},
                                             child.data(),
                                             {{0.1, -0.2, 0.5}, {0.0, 0.0, 0.38268343236, 0.92387953251}}};
  tf2_msgs_msg_dds__TFMessage_ tf{};
  tf.transforms = {1, 1, &t, false};
  EXPECT_EQ(as_sent(pp, tf2_msgs_msg_dds__TFMessage__desc, "rt/wire_tf", &tf), tf_message(tf));
  // One byte written out: 4 (header) + 4 (length) + 8 (stamp) + 4 + 10 ("base_link" and NUL) + 2 (padding to 4)
  // + 4 + 6 ("lidar") + 2 (padding to 8) + 56 (7 doubles).
  EXPECT_EQ(tf_message(tf).size(), 100u);

  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ pose{};
  std::string map = "map";
  pose.header = {{12, 5}, map.data()};
  pose.pose.pose = {{1.5, -2.0, 0.25}, {0.0, 0.0, 0.0, 1.0}};
  for (int i = 0; i < 36; ++i) pose.pose.covariance[i] = 0.01 * i;
  EXPECT_EQ(as_sent(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "rt/wire_pose", &pose),
            pose_with_covariance_stamped(pose));

  nav_msgs_msg_dds__Odometry_ odom{};
  std::string odom_frame = "odom", base = "base_link";
  odom.header = {{7, 8}, odom_frame.data()};
  odom.child_frame_id = base.data();
  odom.pose.pose = {{1, 2, 3}, {0, 0, 0, 1}};
  odom.pose.covariance[35] = 0.5;
  odom.twist.twist = {{0.3, 0, 0}, {0, 0, 0.1}};
  odom.twist.covariance[0] = 0.25;
  CdrBytes c;
  header_of(c, odom.header);
  c.string(odom.child_frame_id);
  pose_of(c, odom.pose.pose);
  doubles(c, odom.pose.covariance, 36);
  c.f64(0.3).f64(0).f64(0).f64(0).f64(0).f64(0.1);
  doubles(c, odom.twist.covariance, 36);
  EXPECT_EQ(as_sent(pp, nav_msgs_msg_dds__Odometry__desc, "rt/wire_odom", &odom), c.message());

  sensor_msgs_msg_dds__Imu_ imu{};
  std::string imu_frame = "imu";
  imu.header = {{9, 10}, imu_frame.data()};
  imu.orientation = {0, 0, 0, 1};
  imu.orientation_covariance[0] = -1;
  imu.angular_velocity = {0.01, 0.02, 0.03};
  imu.linear_acceleration = {0.1, 0.2, 9.81};
  c = CdrBytes();
  header_of(c, imu.header);
  c.f64(0).f64(0).f64(0).f64(1);
  doubles(c, imu.orientation_covariance, 9);
  c.f64(0.01).f64(0.02).f64(0.03);
  doubles(c, imu.angular_velocity_covariance, 9);
  c.f64(0.1).f64(0.2).f64(9.81);
  doubles(c, imu.linear_acceleration_covariance, 9);
  EXPECT_EQ(as_sent(pp, sensor_msgs_msg_dds__Imu__desc, "rt/wire_imu", &imu), c.message());

  const rosgraph_msgs_msg_dds__Clock_ clock{{42, 7}};
  c = CdrBytes();
  c.i32(42).u32(7);
  EXPECT_EQ(as_sent(pp, rosgraph_msgs_msg_dds__Clock__desc, "rt/wire_clock", &clock), c.message());

  // std_msgs/Empty: rosidl's one uint8 member; padded to 4 bytes, the padding named in the header.
  const std_msgs_msg_dds__Empty_ empty{0};
  EXPECT_EQ(as_sent(pp, std_msgs_msg_dds__Empty__desc, "rt/wire_empty", &empty),
            (Bytes{0x00, 0x01, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00}));
  // A service request as rmw_cyclonedds_cpp frames it: the client's id and the sequence number, then the request.
  const std_srvs_srv_dds__Empty_Request_ request{0x0102030405060708ULL, 3, 0};
  c = CdrBytes();
  c.u64(0x0102030405060708ULL).i64(3).u8(0);
  EXPECT_EQ(as_sent(pp, std_srvs_srv_dds__Empty_Request__desc, "rq/wire_serviceRequest", &request), c.message());

  // A cloud of two points as encode_pointcloud2 lays it out (x y z intensity, FLOAT32).
  PointCloud two;
  two.points = {{1, 2, 3}, {4, 5, 6}};
  node::CloudOut cloud;
  cloud.frame_id = "lidar";
  cloud.stamp = node::Stamp{1500000000};
  cloud.cloud = encode_pointcloud2(two);
  const CloudMessage cloud_message(cloud);
  const Bytes cloud_bytes = point_cloud2(cloud_message.msg);
  EXPECT_EQ(as_sent(pp, sensor_msgs_msg_dds__PointCloud2__desc, "rt/wire_points", &cloud_message.msg), cloud_bytes);
  // Header 4, stamp 8, "lidar" 4 + 6 and 2 of padding, height and width 8, the fields' count 4; x, y and z 20 each
  // (4 + 2 for the name, 2 of padding, offset 4, datatype 1, 3 of padding, count 4), intensity 28; is_bigendian 1 and
  // 3 of padding, point_step, row_step and the data's count 12, the data 32, is_dense 1 and 3 of padding.
  EXPECT_EQ(cloud_bytes.size(), 4u + 8 + 4 + 6 + 2 + 8 + 4 + 3 * 20 + 28 + 4 + 12 + 32 + 4);
}

TEST(Ros2Wire, TheNodesMessagesAndEndpointsAreRos2s) {
  DomainClaim domain;
  const fs::path dir = test_folder("wire");
  const fs::path office = node::test::small_office();
  ASSERT_TRUE(fs::exists(office / "complete")) << "see " << office / "cli.log";
  const Dataset data = Dataset::open(office / "run");
  RunningNode node({"-p", "map_file:=" + (office / "map.tsdf").string(), "-p", "last_pose_file:=''", "-p",
                    "cloud_reliability:=reliable", "-p", "map_cloud_points:=500", "-p", "tf_timeout:=10.0", "-p",
                    "backend:=cpu", "-p", "particles:=2000"},
                   dir / "node.log");
  ASSERT_TRUE(node.up);
  const dds_entity_t pp = node.link.participant();
  const Reader pose(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "rt/amcl_pose", latched_qos(1));
  const Reader status(pp, diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics", reliable_qos(1));
  const Reader map_cloud(pp, sensor_msgs_msg_dds__PointCloud2__desc, "rt/tsdf_mcl/map_cloud", latched_qos(1));
  const Reader particles(pp, nav2_msgs_msg_dds__ParticleCloud__desc, "rt/particle_cloud", sensor_data_qos());
  const Reader hypotheses(pp, nav2_msgs_msg_dds__ParticleCloud__desc, "rt/tsdf_mcl/hypotheses", reliable_qos(1));
  for (const Reader* r : {&pose, &status, &map_cloud, &particles, &hypotheses}) {
    ASSERT_TRUE(wait_for_matched(pp, r->handle(), 1, 60s));
  }
  // The map's surface is latched: it is there without a scan.
  const auto surface = take_raw(map_cloud, 60s);
  ASSERT_TRUE(surface);
  const auto& surface_msg = *static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(surface->sample.get());
  EXPECT_GT(surface_msg.width, 100u);
  EXPECT_EQ(surface->bytes, point_cloud2(surface_msg));

  node::test::PlayOptions o;
  o.scans = {0, 1, 2};
  ASSERT_EQ(node::test::play(node.link, data, o).size(), 3u);
  for (const auto& [reader, encode] : std::vector<std::pair<const Reader*, std::function<Bytes(const void*)>>>{
           {&pose,
            [](const void* m) {
              return pose_with_covariance_stamped(
                  *static_cast<const geometry_msgs_msg_dds__PoseWithCovarianceStamped_*>(m));
            }},
           {&status,
            [](const void* m) {
              return diagnostic_array(*static_cast<const diagnostic_msgs_msg_dds__DiagnosticArray_*>(m));
            }},
           {&particles,
            [](const void* m) { return particle_cloud(*static_cast<const nav2_msgs_msg_dds__ParticleCloud_*>(m)); }},
           {&hypotheses,
            [](const void* m) { return particle_cloud(*static_cast<const nav2_msgs_msg_dds__ParticleCloud_*>(m)); }}}) {
    const auto received = take_raw(*reader, 60s);
    ASSERT_TRUE(received) << reader->type().m_typename;
    EXPECT_EQ(received->bytes, encode(received->sample.get())) << reader->type().m_typename;
  }

  // The node's endpoints as `ros2 topic list -v` discovers them: rt/ names, ROS 2's type names, nav2's QoS.
  struct Expected {
    std::string type;
    bool reliable, transient_local;
  };
  const std::map<std::string, Expected> writers = {
      {"rt/amcl_pose", {"geometry_msgs::msg::dds_::PoseWithCovarianceStamped_", true, true}},
      {"rt/particle_cloud", {"nav2_msgs::msg::dds_::ParticleCloud_", false, false}},
      {"rt/tf", {"tf2_msgs::msg::dds_::TFMessage_", true, false}},
      {"rt/diagnostics", {"diagnostic_msgs::msg::dds_::DiagnosticArray_", true, false}},
      {"rt/tsdf_mcl/map_cloud", {"sensor_msgs::msg::dds_::PointCloud2_", true, true}},
      {"rr/reinitialize_global_localizationReply", {"std_srvs::srv::dds_::Empty_Response_", true, false}},
  };
  const std::map<std::string, Expected> readers = {
      {"rt/points", {"sensor_msgs::msg::dds_::PointCloud2_", true, false}},  // cloud_reliability:=reliable here
      {"rt/tf_static", {"tf2_msgs::msg::dds_::TFMessage_", true, true}},
      {"rt/initialpose", {"geometry_msgs::msg::dds_::PoseWithCovarianceStamped_", true, false}},
      {"rq/reinitialize_global_localizationRequest", {"std_srvs::srv::dds_::Empty_Request_", true, false}},
      {"rt/tsdf_mcl/reinitialize_global_localization", {"std_msgs::msg::dds_::Empty_", true, false}},
  };
  dds_guid_t own{};
  dds_get_guid(pp, &own);
  const auto check = [&](dds_entity_t builtin, const std::map<std::string, Expected>& expected) {
    std::size_t found = 0;
    void* samples[64] = {};
    dds_sample_info_t infos[64];
    const dds_return_t n = dds_read(builtin, samples, infos, 64, 64);
    for (dds_return_t i = 0; i < n; ++i) {
      const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      if (!infos[i].valid_data || std::memcmp(e->participant_key.v, own.v, 12) == 0) continue;  // the test's own
      const auto it = expected.find(e->topic_name);
      if (it == expected.end()) continue;
      ++found;
      EXPECT_EQ(e->type_name, it->second.type) << e->topic_name;
      dds_reliability_kind_t reliability;
      dds_durability_kind_t durability;
      dds_duration_t blocking;
      ASSERT_TRUE(dds_qget_reliability(e->qos, &reliability, &blocking));
      ASSERT_TRUE(dds_qget_durability(e->qos, &durability));
      EXPECT_EQ(reliability == DDS_RELIABILITY_RELIABLE, it->second.reliable) << e->topic_name;
      EXPECT_EQ(durability == DDS_DURABILITY_TRANSIENT_LOCAL, it->second.transient_local) << e->topic_name;
    }
    dds_return_loan(builtin, samples, n);
    EXPECT_EQ(found, expected.size());
  };
  const dds_entity_t publications = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  const dds_entity_t subscriptions = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
  check(publications, writers);
  check(subscriptions, readers);
  node.process.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace tsdf_mcl::ros2_node::test
