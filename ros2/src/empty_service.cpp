#include "empty_service.hpp"

#include <atomic>
#include <chrono>
#include <iomanip>
#include <sstream>

#include "ros_names.hpp"
#include "std_srvs.h"

namespace tsdf_mcl::ros2_node {
namespace {

Qos service_qos(dds_entity_t participant) {
  Qos q = reliable_qos(10);  // rmw_qos_profile_services_default
  q.user_data = service_user_data(participant);
  return q;
}

}  // namespace

std::string service_user_data(dds_entity_t participant) {
  static std::atomic<std::uint32_t> services{0};
  dds_guid_t guid{};
  dds_get_guid(participant, &guid);
  std::uint8_t id[16];
  std::copy(guid.v, guid.v + 12, id);
  const std::uint32_t n = ++services;
  for (int i = 0; i < 4; ++i) id[12 + i] = static_cast<std::uint8_t>(n >> (24 - 8 * i));
  std::ostringstream os;
  os << "serviceid=" << std::hex << std::setw(2) << static_cast<int>(id[0]);
  for (int i = 1; i < 16; ++i) os << "." << static_cast<int>(id[i]);
  os << ";";
  return os.str();
}

EmptyService::EmptyService(dds_entity_t participant, const std::string& name, std::function<void()> handler)
    : participant_(participant),
      handler_(std::move(handler)),
      qos_(service_qos(participant)),
      requests_(participant, std_srvs_srv_dds__Empty_Request__desc, dds_request_topic(name), qos_),
      replies_(participant, std_srvs_srv_dds__Empty_Response__desc, dds_reply_topic(name), qos_) {}

void EmptyService::attach(MessageLoop& loop) {
  loop.add(requests_, [this](const Sample& s) { serve(s); });
}

void EmptyService::serve(const Sample& sample) {
  const auto& request = *static_cast<const std_srvs_srv_dds__Empty_Request_*>(sample.get());
  handler_();
  // A client creates its reply reader with its request writer, but discovery may bring them in either order: wait
  // briefly for a reader to match, as rmw_send_response does, or the reply is lost.
  if (replies_.matched() == 0) wait_for_matched(participant_, replies_.handle(), 1, std::chrono::milliseconds(100));
  const std_srvs_srv_dds__Empty_Response_ reply{request.client_guid, request.sequence_number, 0};
  replies_.write(&reply);
}

}  // namespace tsdf_mcl::ros2_node
