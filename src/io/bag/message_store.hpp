#pragma once
// A recording's messages as the bag dataset reads them, whatever stores them: a ROS 1 bag (rosbag_storage,
// src/io/rosbag/), a rosbag2 bag of SQLite3 or MCAP files (src/io/rosbag2/). The stores hand out serialized
// messages; message_codec.hpp decodes them; contents_reader.hpp turns them into a dataset, one code path for all.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace tsdf_mcl::bag_io {

// How a topic's messages are serialized: ROS 1's wire format, or ROS 2's CDR.
enum class WireFormat { ros1, cdr };

struct TopicInfo {
  std::string type;  // as the store spells it: "sensor_msgs/PointCloud2" (ROS 1), "sensor_msgs/msg/PointCloud2"
  std::string md5;   // ROS 1 bags: the definition's MD5 sum ("*" or "" where unknown)
  WireFormat format = WireFormat::ros1;
};

// One message during MessageStore::read: its size and its bytes, read on demand.
class MessageBytes {
 public:
  virtual ~MessageBytes() = default;
  virtual std::size_t size() const = 0;
  // The first min(n, size()) bytes, valid until the next call or the end of the callback. A store that keeps the
  // message in memory hands it out whole; one on disk may read only the prefix asked for (the scans' headers).
  virtual const std::uint8_t* head(std::size_t n) = 0;
  const std::uint8_t* all() { return head(size()); }
};

class MessageStore {
 public:
  virtual ~MessageStore() = default;
  // The bag as errors name it (its path).
  virtual const std::string& name() const = 0;
  virtual const std::map<std::string, TopicInfo>& topics() const = 0;
  // Every message on `topics` (names as topics() spells them) in the recording's order:
  // f(index into topics, ordinal of the message on its topic, its bytes).
  using Visitor = std::function<void(std::size_t topic, std::uint64_t ordinal, MessageBytes& message)>;
  virtual void read(const std::vector<std::string>& topics, const Visitor& f) = 0;
  // What the summary line should add about how the recording was read ("; ..."), or "".
  virtual std::string notes() const { return ""; }
};

// A message held in memory.
class MessageInMemory : public MessageBytes {
 public:
  MessageInMemory(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::size_t size() const override { return size_; }
  const std::uint8_t* head(std::size_t) override { return data_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
};

}  // namespace tsdf_mcl::bag_io
