#pragma once
// Readers and writers of ROS 2 topics over Cyclone's C API, with the QoS rmw_cyclonedds_cpp makes of a ROS 2 profile
// (rmw_node.cpp: create_readwrite_qos: keep last N, reliable or best effort, volatile or transient local with a
// durability service of the same history, no autodispose), and a thread that waits on a waitset for samples and
// hands each to its reader's handler. The node and the tests' client (ros2/test) share them.
#include <dds/dds.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace tsdf_mcl::ros2_node {

struct Qos {
  bool reliable = true;
  bool transient_local = false;
  int depth = 10;
  std::string user_data;  // "serviceid=...;" for a service's endpoints
};
// ROS 2's named profiles as nav2 and tf2_ros use them.
inline Qos sensor_data_qos() { return {false, false, 5, ""}; }                // rclcpp::SensorDataQoS
inline Qos reliable_qos(int depth = 10) { return {true, false, depth, ""}; }  // rclcpp::QoS(depth)
inline Qos latched_qos(int depth = 1) { return {true, true, depth, ""}; }     // .transient_local()

// A sample of an idlc type, freed with its sequences and strings (dds_sample_free) when the last owner goes.
using Sample = std::shared_ptr<void>;

class Reader {
 public:
  Reader(dds_entity_t participant, const dds_topic_descriptor_t& type, const std::string& topic, const Qos& qos);
  dds_entity_t handle() const { return reader_; }
  const dds_topic_descriptor_t& type() const { return type_; }
  // Takes the next valid sample, if any.
  Sample take() const;

 private:
  const dds_topic_descriptor_t& type_;
  dds_entity_t reader_ = 0;
};

class Writer {
 public:
  Writer(dds_entity_t participant, const dds_topic_descriptor_t& type, const std::string& topic, const Qos& qos);
  dds_entity_t handle() const { return writer_; }
  // Throws Error naming the topic where Cyclone refuses the sample.
  void write(const void* sample) const;
  // Readers matched now.
  int matched() const;

 private:
  std::string topic_;
  dds_entity_t writer_ = 0;
};

// Waits until `entity` (a reader or writer) has matched at least `count` endpoints, on its status (no polling).
// False after `timeout`.
bool wait_for_matched(dds_entity_t participant, dds_entity_t entity, int count, std::chrono::milliseconds timeout);

// A thread that waits on a waitset for data on its readers and calls each reader's handler for each sample, until
// it is destroyed (a guard condition wakes it). A handler that throws has its error passed to `on_error`, and the
// loop goes on with the next sample.
class MessageLoop {
 public:
  MessageLoop(dds_entity_t participant, std::function<void(const std::string&)> on_error);
  ~MessageLoop();
  MessageLoop(const MessageLoop&) = delete;
  MessageLoop& operator=(const MessageLoop&) = delete;
  // Before start().
  void add(const Reader& reader, std::function<void(const Sample&)> handler);
  void start();

 private:
  void run();
  struct Entry {
    const Reader* reader;
    std::function<void(const Sample&)> handler;
  };
  dds_entity_t participant_;
  std::function<void(const std::string&)> on_error_;
  dds_entity_t waitset_ = 0, guard_ = 0;
  std::vector<dds_entity_t> conditions_;
  std::vector<Entry> entries_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tsdf_mcl::ros2_node
