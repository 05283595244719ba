// ROS 1 bags through Debian's rosbag_storage, without a ROS master: a MessageStore (message_store.hpp) for the one
// dataset code path of every bag format (contents_reader.hpp), and the scans.
//
// rosbag_storage finds the messages (connections, chunks, compression, the index); the messages themselves are
// decoded from their bytes by tsdf_mcl::ros1 (ros1_messages.hpp: every length checked before allocation, fuzzed),
// not instantiated through roscpp, whose deserializer trusts length fields.
//
// rosbag_storage itself trusts the bag's record lengths (Bag::readHeaderFromBuffer copies what they say), so a
// corrupt bag could crash it. The pass that reads everything but the clouds' points therefore runs in a child
// process, which hands its results back through a pipe: a crash there is one error line here. The parent then
// only opens the bag's index and reads, scan by scan, messages the child has already read whole.
#include <console_bridge/console.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <algorithm>
#include <fstream>
#include <mutex>

#include "../bag/bag_formats.hpp"
#include "../bag/contents_reader.hpp"
#include "../bag/message_codec.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/io/isolated_call.hpp"

namespace tsdf_mcl::bag_io {
namespace fs = std::filesystem;

namespace {

// ------------------------------------------------------------------------------------------- the bag file

// Refuses what is not a ROS 1 bag of format 2.0 before rosbag_storage sees it (open_bag.cpp sent it here for its
// "#ROSBAG V").
void check_bag_file(const fs::path& file) {
  const std::uint64_t size = input_file_size(file, "bag", limits::kMaxBagFileBytes);
  std::ifstream in(file, std::ios::binary);
  char magic[16] = {};
  in.read(magic, sizeof(magic));
  const std::string head(magic, static_cast<std::size_t>(in.gcount()));
  if (head.rfind("#ROSBAG V2.0\n", 0) != 0) {
    throw Error(file.string() + " is a ROS bag of an old format (" + head.substr(1, 11) +
                "); only format 2.0 is read: 'rosbag fix' converts it");
  }
  if (size < 4096)
    throw Error(file.string() + ": truncated ROS bag (" + std::to_string(size) + " bytes: no more than its header)");
}

// Runs f, wording what rosbag_storage (or the memory it asked for) throws as one sentence about the file.
template <typename F>
auto guarded(const fs::path& file, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const rosbag::BagUnindexedException&) {
    throw Error(file.string() + ": the bag is not indexed (its recording was cut off?); 'rosbag reindex' repairs it");
  } catch (const std::bad_alloc&) {
    throw Error(file.string() + ": corrupt or truncated ROS bag (a record asks for more memory than there is)");
  } catch (const std::exception& e) {
    throw Error(file.string() + ": corrupt or truncated ROS bag (rosbag_storage: " + e.what() + ")");
  }
}

void open_read(rosbag::Bag& bag, const fs::path& file) {
  // rosbag_storage logs through console_bridge on stderr; errors reach the user as exceptions, worded once.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  guarded(file, [&] { bag.open(file.string(), rosbag::bagmode::Read); });
}

// One message's bytes, copied out of rosbag_storage.
void read_message(const rosbag::MessageInstance& m, const std::string& what, std::vector<std::uint8_t>& buffer) {
  const std::uint32_t size = m.size();
  if (size > limits::kMaxBagMessageBytes) {
    throw Error(what + " has " + std::to_string(size) + " bytes, more than the limit of " +
                std::to_string(limits::kMaxBagMessageBytes));
  }
  buffer.resize(size);
  ros::serialization::OStream stream(buffer.data(), size);
  m.write(stream);
}

// ----------------------------------------------------------------------------------- the message store

class Ros1Store : public MessageStore {
 public:
  explicit Ros1Store(const fs::path& file) : file_(file), name_(file.string()) {
    open_read(bag_, file);
    guarded(file, [&] {
      rosbag::View view(bag_);
      for (const rosbag::ConnectionInfo* c : view.getConnections()) {
        const auto [it, inserted] = topics_.try_emplace(c->topic, TopicInfo{c->datatype, c->md5sum, WireFormat::ros1});
        if (!inserted && it->second.type != c->datatype) {
          throw Error(name_ + ": topic " + msg::printable_name(c->topic) + " carries two types, " +
                      msg::printable_name(it->second.type) + " and " + msg::printable_name(c->datatype));
        }
      }
    });
  }

  const std::string& name() const override { return name_; }
  const std::map<std::string, TopicInfo>& topics() const override { return topics_; }

  void read(const std::vector<std::string>& topics, const Visitor& f) override {
    guarded(file_, [&] {
      rosbag::View view(bag_, rosbag::TopicQuery(topics));
      std::vector<std::uint8_t> buffer;
      std::vector<std::uint64_t> ordinals(topics.size(), 0);
      for (const rosbag::MessageInstance& m : view) {
        const std::size_t index =
            static_cast<std::size_t>(std::find(topics.begin(), topics.end(), m.getTopic()) - topics.begin());
        if (index == topics.size()) continue;
        read_message(m, name_ + ": message " + std::to_string(ordinals[index]) + " on " + topics[index], buffer);
        MessageInMemory bytes(buffer.data(), buffer.size());
        f(index, ordinals[index]++, bytes);
      }
    });
  }

 private:
  fs::path file_;
  std::string name_;
  rosbag::Bag bag_;
  std::map<std::string, TopicInfo> topics_;
};

// ------------------------------------------------------------------------- child process and pipe

// read_contents in a child process (isolated_call.hpp): a crash inside rosbag_storage is an Error here.
BagContents read_contents_isolated(const fs::path& file, const BagOptions& options) {
  return decode(call_isolated(
      [&] {
        Ros1Store store(file);
        return encode(read_contents(store, options));
      },
      [&](const std::string& how) {
        return file.string() + ": corrupt ROS bag (rosbag_storage crashed reading it: " + how + ")";
      }));
}

// ------------------------------------------------------------------------------------- the scans

class BagScans : public Dataset::ScanSource {
 public:
  BagScans(const fs::path& file, const std::string& topic, const std::vector<std::uint64_t>& ordinals)
      : file_(file), topic_(topic) {
    open_read(bag_, file);
    guarded(file, [&] {
      rosbag::View view(bag_, rosbag::TopicQuery(topic));
      std::uint64_t k = 0;
      auto wanted = ordinals.begin();
      for (auto it = view.begin(); it != view.end() && wanted != ordinals.end(); ++it, ++k) {
        if (k == *wanted) {
          messages_.push_back(*it);
          ++wanted;
        }
      }
    });
    if (messages_.size() != ordinals.size()) throw Error(file.string() + ": the bag changed while it was read");
  }

  PointCloud load(std::size_t i, std::size_t* dropped_non_finite) const override {
    const std::string what = name(i);
    std::vector<std::uint8_t> bytes;
    {
      const std::lock_guard<std::mutex> lock(mutex_);  // rosbag::Bag reads through one file position and buffer
      guarded(file_, [&] { read_message(messages_.at(i), what, bytes); });
    }
    return decode_scan(WireFormat::ros1, bytes.data(), bytes.size(), what, dropped_non_finite);
  }

  std::string name(std::size_t i) const override {
    return file_.string() + ":" + topic_ + "[" + std::to_string(i) + "]";
  }

 private:
  fs::path file_;
  std::string topic_;
  rosbag::Bag bag_;
  std::vector<rosbag::MessageInstance> messages_;  // index entries; they point into bag_
  mutable std::mutex mutex_;
};

}  // namespace

bool ros1_bag_support() { return true; }

OpenedBag open_ros1_bag(const fs::path& file, const BagOptions& options) {
  check_bag_file(file);
  OpenedBag bag;
  bag.contents = read_contents_isolated(file, options);
  bag.scans = std::make_shared<BagScans>(file, bag.contents.points_topic, bag.contents.scan_ordinals);
  return bag;
}

}  // namespace tsdf_mcl::bag_io
