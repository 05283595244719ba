#pragma once
// One rosbag2 storage file, SQLite3 (sqlite_file.cpp) or MCAP (mcap_file.cpp), as the recording (recording.hpp)
// reads it: its topics, its messages in the file's order, and one message again by where it lies.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "../bag/message_store.hpp"

namespace tsdf_mcl::rosbag2 {

struct StoredTopic {
  std::string name;
  std::string type;      // "sensor_msgs/msg/PointCloud2"; "" where the file has no schema for it
  std::string encoding;  // the message encoding: "cdr" (rosbag2's serialization_format), "ros1", ...
};

// Where a message lies in its file; what the numbers mean is the file's business.
struct Locator {
  std::uint64_t a = 0, b = 0;
};

class StorageFile {
 public:
  virtual ~StorageFile() = default;
  virtual const std::vector<StoredTopic>& topics() const = 0;
  // Every message on the topics marked in `wanted` (by topics() index), in the file's order (SQLite3: by
  // timestamp, as rosbag2 plays it; MCAP: as written): f(topic index, where it lies, its bytes).
  using Visitor = std::function<void(std::size_t topic, const Locator& at, bag_io::MessageBytes& message)>;
  virtual void read(const std::vector<bool>& wanted, const Visitor& f) = 0;
  // A message read before, whole, into `out`.
  virtual void load(const Locator& at, std::vector<std::uint8_t>& out) = 0;
  // How the file was read where that is worth a word (an MCAP cut off by a crash), "; ..." or "".
  virtual std::string notes() const { return ""; }
};

// Each throws Error in one sentence naming the file: not of its kind, corrupt, truncated, locked.
std::unique_ptr<StorageFile> open_sqlite_file(const std::filesystem::path& file);
std::unique_ptr<StorageFile> open_mcap_file(const std::filesystem::path& file);

}  // namespace tsdf_mcl::rosbag2
