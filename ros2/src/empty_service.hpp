#pragma once
// A std_srvs/srv/Empty service as rmw_cyclonedds_cpp serves one (rmw_node.cpp: rmw_create_service,
// rmw_send_response), so that `ros2 service call` and rclcpp clients over rmw_cyclonedds_cpp reach it: requests on
// rq<name>Request, replies on rr<name>Reply, each sample led by the client's id and sequence number (std_srvs.idl),
// which the reply repeats; both endpoints carry "serviceid=<id>;" in their user data, by which a client tells that the
// service is available. Clients over other DDS implementations (Fast DDS) frame requests otherwise and are not
// answered: the node's topic triggers serve them (docs/ros2.md).
#include <functional>
#include <string>

#include "dds_endpoints.hpp"

namespace tsdf_mcl::ros2_node {

class EmptyService {
 public:
  // `name`: the service's fully qualified name. `handler` runs for each request, then the reply goes out.
  EmptyService(dds_entity_t participant, const std::string& name, std::function<void()> handler);
  void attach(MessageLoop& loop);

 private:
  void serve(const Sample& request);

  dds_entity_t participant_;
  std::function<void()> handler_;
  Qos qos_;  // both endpoints' user data name the same service id
  Reader requests_;
  Writer replies_;
};

// "serviceid=<id>;": the participant's GUID prefix and a number of this process, as rmw_cyclonedds_cpp's
// csid_to_string writes it.
std::string service_user_data(dds_entity_t participant);

}  // namespace tsdf_mcl::ros2_node
