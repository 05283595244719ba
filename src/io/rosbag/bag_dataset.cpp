// Dataset::open_bag: a ROS 1 bag as a dataset, read with Debian's rosbag_storage, without a ROS master.
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
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>

#include "bag_contents.hpp"
#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/io/isolated_call.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros1_messages.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

namespace {

std::string seconds(double t) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.3f", t);
  return buf;
}

std::string in_quotes(const std::string& s) { return "'" + ros1::printable_name(s) + "'"; }
std::string shown(const std::string& s) { return ros1::printable_name(s); }

using bag_io::BagContents;  // bag_contents.hpp: what the child process hands to the parent
using bag_io::decode;
using bag_io::encode;

// ------------------------------------------------------------------------------------------- the bag file

// Refuses what is not a ROS 1 bag before rosbag_storage sees it, naming what it is instead where that is clear.
void check_bag_file(const fs::path& file) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) {
    if (fs::exists(file / "metadata.yaml", ec)) {
      throw Error(file.string() + " is a ROS 2 bag (a folder with metadata.yaml); tsdf-mcl reads ROS 1 bags (.bag)");
    }
    throw Error("bag " + file.string() + " is a directory");
  }
  const std::uint64_t size = input_file_size(file, "bag", limits::kMaxBagFileBytes);
  std::ifstream in(file, std::ios::binary);
  char magic[16] = {};
  in.read(magic, sizeof(magic));
  const std::string head(magic, static_cast<std::size_t>(in.gcount()));
  if (head.rfind("#ROSBAG V2.0\n", 0) == 0) {
    if (size < 4096)
      throw Error(file.string() + ": truncated ROS bag (" + std::to_string(size) + " bytes: no more than its header)");
    return;
  }
  if (head.rfind("#ROSBAG V", 0) == 0) {
    throw Error(file.string() + " is a ROS bag of an old format (" + head.substr(1, 11) +
                "); only format 2.0 is read: 'rosbag fix' converts it");
  }
  if (head.rfind("SQLite format 3", 0) == 0) {
    throw Error(file.string() + " is a ROS 2 bag (SQLite); tsdf-mcl reads ROS 1 bags (.bag)");
  }
  throw Error(file.string() + " is not a ROS 1 bag (it does not start with '#ROSBAG V2.0')");
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

struct TopicInfo {
  std::string datatype, md5;
};

std::map<std::string, TopicInfo> topics_of(rosbag::Bag& bag, const fs::path& file) {
  return guarded(file, [&] {
    std::map<std::string, TopicInfo> out;
    rosbag::View view(bag);
    for (const rosbag::ConnectionInfo* c : view.getConnections()) {
      const auto [it, inserted] = out.try_emplace(c->topic, TopicInfo{c->datatype, c->md5sum});
      if (!inserted && it->second.datatype != c->datatype) {
        throw Error(file.string() + ": topic " + shown(c->topic) + " carries two types, " + shown(it->second.datatype) +
                    " and " + shown(c->datatype));
      }
    }
    return out;
  });
}

// The bag's spelling of `wanted` (with or without its leading '/'), or "".
std::string find_topic(const std::map<std::string, TopicInfo>& topics, const std::string& wanted) {
  if (topics.count(wanted)) return wanted;
  const std::string bare = wanted.rfind('/', 0) == 0 ? wanted.substr(1) : wanted;
  for (const std::string& t : {bare, "/" + bare}) {
    if (topics.count(t)) return t;
  }
  return "";
}

// The bag's topic `wanted` (`option` names where it came from), which must carry one of `types`.
std::string require_topic(const std::map<std::string, TopicInfo>& topics, const fs::path& file,
                          const std::string& wanted, const std::string& option,
                          std::initializer_list<ros1::MessageType> types) {
  const std::string topic = find_topic(topics, wanted);
  std::string type_names;
  for (const ros1::MessageType& t : types) type_names += (type_names.empty() ? "" : " or ") + std::string(t.name);
  if (topic.empty()) {
    std::string same_type;
    for (const auto& [name, info] : topics) {
      for (const ros1::MessageType& t : types) {
        if (info.datatype == t.name) same_type += (same_type.empty() ? "" : ", ") + shown(name);
      }
    }
    throw Error("bag " + file.string() + " has no topic " + shown(wanted) + " (" + option + "); its " + type_names +
                " topics: " + (same_type.empty() ? "none" : same_type));
  }
  const TopicInfo& info = topics.at(topic);
  for (const ros1::MessageType& t : types) {
    if (info.datatype != t.name) continue;
    if (info.md5 != t.md5 && info.md5 != "*") {
      throw Error("bag " + file.string() + ": topic " + shown(topic) + " carries a " + t.name +
                  " of another definition (md5 " + shown(info.md5) + ", expected " + t.md5 + ")");
    }
    return topic;
  }
  throw Error("bag " + file.string() + ": topic " + shown(topic) + " (" + option + ") carries " + shown(info.datatype) +
              ", not " + type_names);
}

// Calls f(bytes, size, ordinal) for every message on `topic`, in the bag's order (receive time).
template <typename F>
void for_each_message(rosbag::Bag& bag, const fs::path& file, const std::string& topic, F&& f) {
  guarded(file, [&] {
    rosbag::View view(bag, rosbag::TopicQuery(topic));
    std::vector<std::uint8_t> buffer;
    std::uint64_t ordinal = 0;
    for (const rosbag::MessageInstance& m : view) {
      const std::uint32_t size = m.size();
      if (size > limits::kMaxBagMessageBytes) {
        throw Error(file.string() + ": message " + std::to_string(ordinal) + " on " + topic + " has " +
                    std::to_string(size) + " bytes, more than the limit of " +
                    std::to_string(limits::kMaxBagMessageBytes));
      }
      buffer.resize(size);
      ros::serialization::OStream stream(buffer.data(), size);
      m.write(stream);
      f(buffer.data(), buffer.size(), ordinal++);
    }
  });
}

std::string message_name(const fs::path& file, const std::string& topic, std::uint64_t ordinal) {
  return file.string() + ": " + shown(topic) + " message " + std::to_string(ordinal);
}

// ------------------------------------------------------------------------------------ poses from a topic

// Stamped poses parent_T_child from nav_msgs/Odometry or geometry_msgs/PoseStamped messages, by time.
struct PoseSeries {
  std::string topic, parent, child;
  std::vector<std::pair<double, Pose>> samples;

  void sort() {
    std::stable_sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    // Equal stamps: the later message stands.
    std::vector<std::pair<double, Pose>> unique;
    for (const auto& s : samples) {
      if (!unique.empty() && unique.back().first == s.first)
        unique.back() = s;
      else
        unique.push_back(s);
    }
    samples = std::move(unique);
  }
  bool covers(double t) const {
    return !samples.empty() && t >= samples.front().first - 1e-9 && t <= samples.back().first + 1e-9;
  }
  Pose at(double t) const {
    auto hi = std::lower_bound(samples.begin(), samples.end(), t, [](const auto& s, double v) { return s.first < v; });
    if (hi == samples.end()) return samples.back().second;
    if (hi == samples.begin() || hi->first - t <= 1e-9) return hi->second;
    const auto lo = std::prev(hi);
    if (t - lo->first <= 1e-9) return lo->second;
    return interpolate_pose(lo->second, hi->second, (t - lo->first) / (hi->first - lo->first));
  }
};

PoseSeries read_pose_topic(rosbag::Bag& bag, const fs::path& file, const std::string& topic, const TopicInfo& info,
                           const std::string& default_child) {
  PoseSeries series;
  series.topic = topic;
  const bool odometry = info.datatype == ros1::kOdometry.name;
  for_each_message(bag, file, topic, [&](const std::uint8_t* data, std::size_t size, std::uint64_t k) {
    const std::string what = message_name(file, topic, k);
    const ros1::PoseMessage m =
        odometry ? ros1::decode_odometry(data, size, what) : ros1::decode_pose_stamped(data, size, what);
    const std::string child = m.child_frame_id.empty() ? default_child : m.child_frame_id;
    if (m.header.frame_id.empty()) throw Error(what + ": empty header.frame_id");
    if (series.samples.empty()) {
      series.parent = m.header.frame_id;
      series.child = child;
    } else if (m.header.frame_id != series.parent || child != series.child) {
      throw Error(what + " is " + in_quotes(m.header.frame_id) + " -> " + in_quotes(child) + ", the first message " +
                  in_quotes(series.parent) + " -> " + in_quotes(series.child));
    }
    series.samples.emplace_back(m.header.stamp(), m.pose);
  });
  if (series.samples.empty()) throw Error("bag " + file.string() + ": topic " + topic + " holds no messages");
  series.sort();
  return series;
}

// ------------------------------------------------------------------------------------------- the pass

// read_contents' stages over one open bag, in order; each fills its part of the contents.
class ContentsReader {
 public:
  ContentsReader(const fs::path& file, const BagOptions& options)
      : file_(file), options_(options), name_(file.string()) {
    open_read(bag_, file);
    topics_ = topics_of(bag_, file);
  }

  BagContents read() {
    read_scan_headers();
    read_tf();
    find_odometry_and_truth();
    place_scans();
    read_imu();
    summarize();
    return std::move(out_);
  }

 private:
  void read_scan_headers() {
    // Scans: header stamps and frames, in the bag's order.
    out_.points_topic = require_topic(topics_, file_, options_.points_topic, "the points topic", {ros1::kPointCloud2});
    for_each_message(bag_, file_, out_.points_topic, [&](const std::uint8_t* data, std::size_t size, std::uint64_t k) {
      const std::string what = message_name(file_, out_.points_topic, k);
      const ros1::Header h = ros1::decode_header(data, size, what);
      if (k == 0) {
        cloud_frame_ = h.frame_id;
      } else if (h.frame_id != cloud_frame_) {
        throw Error(what + " is in frame " + in_quotes(h.frame_id) + ", the first scan in " + in_quotes(cloud_frame_));
      }
      const double t = h.stamp();
      if (!stamps_.empty() && !(t > stamps_.back())) {
        throw Error("bag " + name_ + ": scans out of order on " + out_.points_topic + ": scan " + std::to_string(k) +
                    " is stamped " + seconds(t) + " s, not after scan " + std::to_string(k - 1) + " (" +
                    seconds(stamps_.back()) + " s)");
      }
      stamps_.push_back(t);
    });
    if (stamps_.empty()) throw Error("bag " + name_ + ": topic " + out_.points_topic + " holds no messages");
  }

  void read_tf() {
    // tf: /tf dynamic, /tf_static static; either may be absent.
    for (const auto& [wanted, is_static] :
         {std::pair{options_.tf_topic, false}, std::pair{options_.tf_static_topic, true}}) {
      if (wanted.empty() || find_topic(topics_, wanted).empty()) continue;
      const std::string topic = require_topic(topics_, file_, wanted, is_static ? "static tf" : "tf",
                                              {ros1::kTfMessage, ros1::kOldTfMessage});
      const bool static_topic = is_static;
      for_each_message(bag_, file_, topic, [&](const std::uint8_t* data, std::size_t size, std::uint64_t k) {
        const std::string what = message_name(file_, topic, k);
        for (const ros1::TransformStamped& t : ros1::decode_tf_message(data, size, what)) {
          try {
            tree_.add(t.header.frame_id, t.child_frame_id, t.header.stamp(), t.transform, static_topic);
          } catch (const Error& e) {
            throw Error(what + ": " + e.what());
          }
        }
      });
    }
  }

  Error tf_error(const Error& e) const { return Error("bag " + name_ + ": " + e.what()); }
  void needs_cloud_frame(const std::string& why) const {
    if (cloud_frame_.empty()) {
      throw Error("bag " + name_ + ": the scans on " + out_.points_topic + " have no header.frame_id, which " + why +
                  " needs");
    }
  }

  void find_odometry_and_truth() {
    // Odometry: a topic, or tf odom_frame -> base_frame.
    if (!options_.odom_topic.empty()) {
      const std::string topic =
          require_topic(topics_, file_, options_.odom_topic, "the odometry topic", {ros1::kOdometry});
      odom_series_ = read_pose_topic(bag_, file_, topic, topics_.at(topic), options_.base_frame);
      odometry_note_ = "odometry from " + topic + " (" + in_quotes(odom_series_->parent) + " -> " +
                       in_quotes(odom_series_->child) + ")";
    } else if (tree_.has_frame(options_.odom_frame)) {
      odom_from_tf_ = true;
      odometry_note_ = "odometry from tf " + in_quotes(options_.odom_frame) + " -> " + in_quotes(options_.base_frame);
    } else {
      out_.missing_odometry = "bag " + name_ + " has no odometry: no tf frame " + in_quotes(options_.odom_frame) +
                              " (--odom_frame) and no --odom_topic";
    }

    // Ground truth: world_T_child from a topic.
    if (!options_.ground_truth_topic.empty()) {
      const std::string topic = require_topic(topics_, file_, options_.ground_truth_topic, "the ground truth topic",
                                              {ros1::kOdometry, ros1::kPoseStamped});
      truth_ = read_pose_topic(bag_, file_, topic, topics_.at(topic), options_.base_frame);
    } else {
      out_.missing_poses = "bag " + name_ + " has no ground truth (--ground_truth_topic)";
    }
  }

  void place_scans() {
    // Per scan: odom_T_sensor and world_T_sensor, where every source covers the stamp; scans outside are left out.
    std::pair<double, double> range{-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    const auto narrow = [&](std::pair<double, double> r) {
      range.first = std::max(range.first, r.first);
      range.second = std::min(range.second, r.second);
    };
    if (odom_from_tf_ || odom_series_) needs_cloud_frame("odometry");
    if (truth_) needs_cloud_frame("ground truth");
    try {
      if (odom_from_tf_) {
        narrow(tree_.coverage(options_.odom_frame, options_.base_frame));
        narrow(tree_.coverage(options_.base_frame, cloud_frame_));
      }
      if (odom_series_) {
        narrow({odom_series_->samples.front().first, odom_series_->samples.back().first});
        narrow(tree_.coverage(odom_series_->child, cloud_frame_));
      }
      if (truth_) {
        narrow({truth_->samples.front().first, truth_->samples.back().first});
        narrow(tree_.coverage(truth_->child, cloud_frame_));
      }
    } catch (const Error& e) {
      throw tf_error(e);
    }
    for (std::size_t k = 0; k < stamps_.size(); ++k) {
      const double t = stamps_[k];
      if (t < range.first - 1e-9) {
        ++before_;
        continue;
      }
      if (t > range.second + 1e-9) {
        ++after_;
        continue;
      }
      out_.scan_ordinals.push_back(k);
      out_.times.push_back(t);
      if (odom_from_tf_) {
        out_.odometry.push_back(tree_.lookup(options_.odom_frame, options_.base_frame, t) *
                                tree_.lookup(options_.base_frame, cloud_frame_, t));
      } else if (odom_series_) {
        out_.odometry.push_back(odom_series_->at(t) * tree_.lookup(odom_series_->child, cloud_frame_, t));
      }
      if (truth_) out_.poses.push_back(truth_->at(t) * tree_.lookup(truth_->child, cloud_frame_, t));
    }
    if (out_.times.empty()) {
      throw Error("bag " + name_ + ": none of the " + std::to_string(stamps_.size()) + " scans (" +
                  seconds(stamps_.front()) + ".." + seconds(stamps_.back()) +
                  " s) lies within the times of the odometry and ground truth (" + seconds(range.first) + ".." +
                  seconds(range.second) + " s)");
    }
  }

  void read_imu() {
    // IMU: specific force rotated into the clouds' frame.
    if (!options_.imu_topic.empty()) {
      const std::string topic = require_topic(topics_, file_, options_.imu_topic, "the IMU topic", {ros1::kImu});
      std::size_t outside = 0;
      std::map<std::string, std::pair<double, double>> cover;  // per IMU frame, where tf reaches the clouds' frame
      for_each_message(bag_, file_, topic, [&](const std::uint8_t* data, std::size_t size, std::uint64_t k) {
        const std::string what = message_name(file_, topic, k);
        const ros1::Imu m = ros1::decode_imu(data, size, what);
        const std::string frame = m.header.frame_id.empty() ? cloud_frame_ : m.header.frame_id;
        const double t = m.header.stamp();
        if (frame != cloud_frame_) needs_cloud_frame("the IMU");
        try {
          auto it = cover.find(frame);
          if (it == cover.end()) it = cover.emplace(frame, tree_.coverage(cloud_frame_, frame)).first;
          if (t < it->second.first - 1e-9 || t > it->second.second + 1e-9) {
            ++outside;
            return;
          }
          out_.imu.push_back({t, tree_.lookup(cloud_frame_, frame, t).linear() * m.linear_acceleration});
        } catch (const Error& e) {
          throw tf_error(e);
        }
      });
      std::stable_sort(out_.imu.begin(), out_.imu.end(),
                       [](const ImuSample& a, const ImuSample& b) { return a.time < b.time; });
      imu_note_ = "; " + std::to_string(out_.imu.size()) + " IMU samples from " + topic;
      if (outside > 0) imu_note_ += " (" + std::to_string(outside) + " outside the tf to the clouds' frame left out)";
    }
  }

  void summarize() {
    out_.summary = "bag " + name_ + ": " + std::to_string(out_.times.size()) + " scans on " + out_.points_topic +
                   " (frame " + in_quotes(cloud_frame_) + ", " + seconds(out_.times.front()) + ".." +
                   seconds(out_.times.back()) + " s); " + (odometry_note_.empty() ? "no odometry" : odometry_note_) +
                   "; " +
                   (truth_ ? "ground truth from " + truth_->topic + " (" + in_quotes(truth_->parent) + " -> " +
                                 in_quotes(truth_->child) + ")"
                           : "no ground truth") +
                   imu_note_;
    if (before_ + after_ > 0) {
      out_.summary += "; left out " + std::to_string(before_) + " scans before and " + std::to_string(after_) +
                      " after the odometry / ground truth";
    }
  }

  const fs::path& file_;
  const BagOptions& options_;
  const std::string name_;
  rosbag::Bag bag_;
  std::map<std::string, TopicInfo> topics_;
  BagContents out_;
  std::vector<double> stamps_;  // every scan's header stamp, in the bag's order
  std::string cloud_frame_;
  TransformTree tree_;
  std::optional<PoseSeries> odom_series_;  // odometry from a topic, or
  bool odom_from_tf_ = false;              // from tf
  std::string odometry_note_, imu_note_;
  std::optional<PoseSeries> truth_;
  std::size_t before_ = 0, after_ = 0;  // scans left out before and after the odometry / ground truth
};

BagContents read_contents(const fs::path& file, const BagOptions& options) {
  return ContentsReader(file, options).read();
}

// ------------------------------------------------------------------------- child process and pipe

// read_contents in a child process (isolated_call.hpp): a crash inside rosbag_storage is an Error here.
BagContents read_contents_isolated(const fs::path& file, const BagOptions& options) {
  return decode(call_isolated([&] { return encode(read_contents(file, options)); },
                              [&](const std::string& how) {
                                return file.string() + ": corrupt ROS bag (rosbag_storage crashed reading it: " + how +
                                       ")";
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
      guarded(file_, [&] {
        const rosbag::MessageInstance& m = messages_.at(i);
        const std::uint32_t size = m.size();
        if (size > limits::kMaxBagMessageBytes) throw Error(what + ": message larger than the limit");
        bytes.resize(size);
        ros::serialization::OStream stream(bytes.data(), size);
        m.write(stream);
      });
    }
    const ros1::PointCloud2Message msg = ros1::decode_pointcloud2_message(bytes.data(), bytes.size(), what);
    PointCloud2Stats stats;
    PointCloud cloud = decode_pointcloud2(msg.layout, bytes.data() + msg.data_offset, msg.data_size, &stats, what);
    // The policy of Dataset::load_scan: no points, or no finite point, is an error naming the scan.
    if (stats.points == 0) throw Error(what + ": empty scan (a PointCloud2 of 0 points)");
    if (cloud.empty()) {
      throw Error(what + ": no finite points (" + std::to_string(stats.dropped_non_finite) +
                  " NaN/Inf points dropped)");
    }
    if (dropped_non_finite) *dropped_non_finite = stats.dropped_non_finite;
    return cloud;
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

bool Dataset::bag_support() { return true; }

Dataset Dataset::open_bag(const fs::path& file, const BagOptions& options) {
  if (options.points_topic.empty()) {
    throw Error("no points topic given (--points: the sensor_msgs/PointCloud2 topic of the scans)");
  }
  check_bag_file(file);
  BagContents contents = read_contents_isolated(file, options);
  Dataset ds;
  ds.dir_ = file;
  ds.source_ = std::make_shared<BagScans>(file, contents.points_topic, contents.scan_ordinals);
  ds.times_ = std::move(contents.times);
  ds.odometry_ = std::move(contents.odometry);
  ds.poses_ = std::move(contents.poses);
  ds.imu_ = std::move(contents.imu);
  ds.summary_ = std::move(contents.summary);
  ds.missing_odometry_ = std::move(contents.missing_odometry);
  ds.missing_poses_ = std::move(contents.missing_poses);
  return ds;
}

}  // namespace tsdf_mcl
