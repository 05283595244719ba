#pragma once
// The ROS 2 node over DDS as a NodeLink (node_core/test/node_link.hpp): a client of the test's own, built from ROS 2's
// message definitions (ros2/idl) with Cyclone's idlc, on the loopback interface in a domain of the test's own. The
// scenarios every transport shares drive tsdf_mcl_ros2 through it. Waits are on what its readers received (a
// condition variable fed by a DDS waitset thread) or on matched-endpoint status, never on a timer.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "dds_domain.hpp"
#include "dds_endpoints.hpp"
#include "heard_record.hpp"
#include "node_link.hpp"

namespace tsdf_mcl::ros2_node::test {

namespace fs = std::filesystem;

// A DDS domain id no other test on this machine uses while this object lives (a lock file per id in the temporary
// folder; a lock left by a process that died is taken over). Sets ROS_DOMAIN_ID and ROS_LOCALHOST_ONLY=1 for this
// process and the nodes it starts.
class DomainClaim {
 public:
  DomainClaim();
  ~DomainClaim();
  int id() const { return id_; }

 private:
  int id_ = -1;
  fs::path lock_;
};

class DdsLink : public node::test::NodeLink {
 public:
  // Joins the domain of the environment; `node` is the tsdf_mcl_ros2 process the link talks to.
  DdsLink(node::test::Child& node, double transform_tolerance);
  ~DdsLink() override;

  // The node's readers matched this link's writers and its writers this link's readers.
  bool connected(std::chrono::seconds timeout);
  dds_entity_t participant() const { return participant_.handle(); }

  void tf(const std::vector<node::TransformMsg>& transforms, bool is_static) override;
  void cloud(const PointCloud& cloud, const node::RawStamp& stamp, const std::string& frame) override;
  void odometry(const node::OdometryMsg& odometry) override;
  void imu(const node::ImuMsg& imu) override;
  void clock(const node::RawStamp& now) override;
  void initial_pose(const node::InitialPoseMsg& pose) override;
  // nav2's service, as an rmw_cyclonedds_cpp client calls it; fails the test if no reply comes.
  void global_localization() override;
  // The topic trigger (std_msgs/Empty on ~/reinitialize_global_localization).
  void trigger_global_localization();
  // Calls std_srvs/Empty service `name` (fully qualified); true once the reply for this call came.
  bool call_service(const std::string& name, std::chrono::seconds timeout);
  std::optional<node::test::Heard> heard(const node::RawStamp& scan, std::chrono::seconds timeout) override;
  std::optional<node::TransformOut> map_odom(const node::RawStamp& scan, std::chrono::seconds timeout) override;
  bool alive() override { return node_.running(); }

 private:
  node::test::Child& node_;
  node::test::HeardRecord heard_;
  Participant participant_;
  Writer points_, odom_, imu_, tf_, tf_static_, initial_pose_, clock_, trigger_;
  Reader status_, pose_, tf_in_;
  std::unique_ptr<MessageLoop> loop_;
  std::int64_t service_calls_ = 0;
};

}  // namespace tsdf_mcl::ros2_node::test
