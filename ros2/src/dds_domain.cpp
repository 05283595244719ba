#include "dds_domain.hpp"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

constexpr unsigned long kMaxDomainId = 232;  // Cyclone's port mapping: 7400 + 250 * id + ... < 65536

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// Linux keeps IFF_MULTICAST (0x1000) in the interface's flags; most loopback interfaces lack it, and Cyclone then
// warns on every start that it disables multicast.
bool loopback_has_multicast() {
  std::ifstream in("/sys/class/net/lo/flags");
  unsigned long flags = 0;
  in >> std::hex >> flags;
  return in && (flags & 0x1000) != 0;
}

std::string peers_xml(const std::string& static_peers, bool localhost) {
  std::string peers = localhost ? "<Peer address=\"localhost\"/>" : "";
  std::stringstream in(static_peers);
  for (std::string peer; std::getline(in, peer, ';');) {
    if (peer.empty()) continue;
    if (peer.find_first_of("<>\"&") != std::string::npos) {
      throw Error("ROS_STATIC_PEERS: '" + one_line(peer) + "' is not a host name or address");
    }
    peers += "<Peer address=\"" + peer + "\"/>";
  }
  return peers.empty() ? "" : "<Peers>" + peers + "</Peers>";
}

}  // namespace

DomainConfig domain_from_environment() {
  DomainConfig c;
  if (const std::string id = env("ROS_DOMAIN_ID"); !id.empty()) {
    char* end = nullptr;
    errno = 0;
    const unsigned long v = std::strtoul(id.c_str(), &end, 10);
    if (*end != '\0' || errno != 0 || id.front() == '-' || v > kMaxDomainId) {
      throw Error("ROS_DOMAIN_ID must be a whole number in 0.." + std::to_string(kMaxDomainId) + ", got '" +
                  one_line(id) + "'");
    }
    c.id = static_cast<std::uint32_t>(v);
  }
  std::string range = env("ROS_AUTOMATIC_DISCOVERY_RANGE");
  if (range.empty() && env("ROS_LOCALHOST_ONLY") == "1") range = "LOCALHOST";
  c.described = "domain " + std::to_string(c.id);
  std::string xml;
  if (range == "LOCALHOST") {
    xml = "<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>" +
          std::string(loopback_has_multicast() ? "" : "<AllowMulticast>false</AllowMulticast>") +
          "</General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
          "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>" +
          peers_xml(env("ROS_STATIC_PEERS"), true) + "</Discovery>";
    c.described += ", localhost only";
  } else if (range == "OFF") {
    // As rmw_cyclonedds_cpp: a domain tag of this process's own, which no other participant shares.
    xml =
        "<General><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>none"
        "</ParticipantIndex><Tag>ros_discovery_off_" +
        std::to_string(getpid()) + "</Tag></Discovery>";
    c.described += ", discovery off";
  } else if (range == "SUBNET") {
    if (const std::string peers = peers_xml(env("ROS_STATIC_PEERS"), false); !peers.empty()) {
      xml = "<Discovery>" + peers + "</Discovery>";
    }
  } else if (!range.empty() && range != "SYSTEM_DEFAULT") {
    throw Error("ROS_AUTOMATIC_DISCOVERY_RANGE must be LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT, got '" +
                one_line(range) + "'");
  }
  if (!xml.empty()) c.xml = "<CycloneDDS><Domain>" + xml + "</Domain></CycloneDDS>";
  // Cyclone reads CYCLONEDDS_URI only when no configuration is given: appended, as rmw_cyclonedds_cpp does.
  if (const std::string uri = env("CYCLONEDDS_URI"); !uri.empty()) c.xml += (c.xml.empty() ? "" : ",") + uri;
  return c;
}

Participant::Participant(const DomainConfig& config) {
  if (!config.xml.empty()) {
    domain_ = dds_create_domain(config.id, config.xml.c_str());
    if (domain_ < 0) {
      throw Error("cannot create DDS " + config.described + ": " + dds_strretcode(domain_) + " (check CYCLONEDDS_URI)");
    }
  }
  dds_qos_t* qos = dds_create_qos();
  const std::string user_data = "enclave=/;";
  dds_qset_userdata(qos, user_data.data(), user_data.size());
  participant_ = dds_create_participant(config.id, qos, nullptr);
  dds_delete_qos(qos);
  if (participant_ < 0) {
    const dds_return_t rc = participant_;
    participant_ = 0;
    if (domain_ > 0) dds_delete(domain_);
    throw Error("cannot join DDS " + config.described + ": " + dds_strretcode(rc));
  }
}

Participant::~Participant() {
  if (participant_ > 0) dds_delete(participant_);
  if (domain_ > 0) dds_delete(domain_);
}

}  // namespace tsdf_mcl::ros2_node
