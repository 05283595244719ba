#pragma once
// The DDS domain a ROS 2 node joins, from the environment as rmw_cyclonedds_cpp reads it (rmw_node.cpp:
// check_create_domain): ROS_DOMAIN_ID (default 0), ROS_LOCALHOST_ONLY=1 (Humble) or
// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST|OFF|SUBNET|SYSTEM_DEFAULT and ROS_STATIC_PEERS (Jazzy), and CYCLONEDDS_URI
// appended, so that a user's Cyclone configuration still applies. Localhost only is the loopback interface, with
// unicast discovery of the participants on this machine (Jazzy's way, which works where the loopback interface
// has no multicast, as on most Linux machines).
#include <dds/dds.h>

#include <cstdint>
#include <string>

namespace tsdf_mcl::ros2_node {

struct DomainConfig {
  std::uint32_t id = 0;
  std::string xml;        // Cyclone configuration for dds_create_domain ("" for Cyclone's default)
  std::string described;  // "domain 0, localhost only", for the start-up line
};

// Throws Error for a ROS_DOMAIN_ID that is not a whole number in 0..232 (Cyclone's ports end there) or an unknown
// ROS_AUTOMATIC_DISCOVERY_RANGE.
DomainConfig domain_from_environment();

// A participant of the domain, user data "enclave=/;" as rmw_cyclonedds_cpp sets it; deleted with everything
// created under it when this goes.
class Participant {
 public:
  explicit Participant(const DomainConfig& config);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  dds_entity_t handle() const { return participant_; }

 private:
  dds_entity_t domain_ = 0;
  dds_entity_t participant_ = 0;
};

}  // namespace tsdf_mcl::ros2_node
