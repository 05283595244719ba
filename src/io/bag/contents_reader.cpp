#include "contents_reader.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <optional>

#include "message_codec.hpp"
#include "pose_series.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl::bag_io {
namespace {

std::string seconds(double t) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.3f", t);
  return buf;
}

using msg::quoted_name;
std::string shown(const std::string& s) { return msg::printable_name(s); }

// Enough bytes of a PointCloud2 message for its header whatever its frame_id (within reason): a store on disk reads
// only this much of each scan while the bag is opened.
constexpr std::size_t kHeaderPrefix = 4096;

// What a topic is read for; one topic may serve several (odometry and ground truth from one topic).
enum class Role { points, tf, tf_static, odometry, ground_truth, imu };

struct ImuMessage {
  double time;
  std::string frame;
  Eigen::Vector3d acceleration;
};

class ContentsReader {
 public:
  ContentsReader(MessageStore& store, const BagOptions& options)
      : store_(store), options_(options), name_(store.name()), topics_(store.topics()) {
    for (const auto& [topic, info] : topics_) {
      if (info.format == WireFormat::cdr) names_format_ = WireFormat::cdr;
    }
  }

  BagContents read() {
    choose_topics();
    read_messages();
    if (stamps_.empty()) throw Error("bag " + name_ + ": topic " + out_.points_topic + " holds no messages");
    for (std::optional<PoseSeries>* series : {&odom_series_, &truth_}) {
      if (!*series) continue;
      if ((*series)->samples.empty())
        throw Error("bag " + name_ + ": topic " + (*series)->topic + " holds no messages");
      (*series)->sort();
    }
    find_odometry_and_truth();
    place_scans();
    place_imu();
    summarize();
    return std::move(out_);
  }

 private:
  // The bag's spelling of `wanted` (with or without its leading '/'), or "".
  std::string find_topic(const std::string& wanted) const {
    if (topics_.count(wanted)) return wanted;
    const std::string bare = wanted.rfind('/', 0) == 0 ? wanted.substr(1) : wanted;
    for (const std::string& t : {bare, "/" + bare}) {
      if (topics_.count(t)) return t;
    }
    return "";
  }

  // The bag's topic `wanted` (`option` says what for), which must carry one of `kinds`; returns it and its kind.
  std::pair<std::string, MessageKind> require_topic(const std::string& wanted, const std::string& option,
                                                    std::initializer_list<MessageKind> kinds) const {
    const std::string topic = find_topic(wanted);
    const WireFormat format = topic.empty() ? names_format_ : topics_.at(topic).format;
    std::string type_names;
    for (MessageKind k : kinds) {
      for (const TypeName& t : bag_io::type_names(k, format)) {
        type_names += (type_names.empty() ? "" : " or ") + std::string(t.name);
      }
    }
    if (topic.empty()) {
      std::string same_type;
      for (const auto& [name, info] : topics_) {
        const std::optional<MessageKind> kind = kind_of(info);
        if (kind && std::find(kinds.begin(), kinds.end(), *kind) != kinds.end()) {
          same_type += (same_type.empty() ? "" : ", ") + shown(name);
        }
      }
      throw Error("bag " + name_ + " has no topic " + shown(wanted) + " (" + option + "); its " + type_names +
                  " topics: " + (same_type.empty() ? "none" : same_type) + store_.notes());
    }
    const TopicInfo& info = topics_.at(topic);
    const std::optional<MessageKind> kind = kind_of(info);
    if (!kind || std::find(kinds.begin(), kinds.end(), *kind) == kinds.end()) {
      throw Error("bag " + name_ + ": topic " + shown(topic) + " (" + option + ") carries " + shown(info.type) +
                  ", not " + type_names);
    }
    for (const TypeName& t : bag_io::type_names(*kind, format)) {
      if (t.md5 && info.type == t.name && !info.md5.empty() && info.md5 != t.md5 && info.md5 != "*") {
        throw Error("bag " + name_ + ": topic " + shown(topic) + " carries a " + t.name +
                    " of another definition (md5 " + shown(info.md5) + ", expected " + t.md5 + ")");
      }
    }
    return {topic, *kind};
  }

  void add_role(const std::string& topic, Role role, MessageKind kind) {
    const auto it = std::find(read_.begin(), read_.end(), topic);
    const std::size_t index = static_cast<std::size_t>(it - read_.begin());
    if (it == read_.end()) {
      read_.push_back(topic);
      roles_.emplace_back();
    }
    roles_[index].emplace_back(role, kind);
  }

  void choose_topics() {
    const auto [points, points_kind] =
        require_topic(options_.points_topic, "the points topic", {MessageKind::pointcloud2});
    out_.points_topic = points;
    add_role(points, Role::points, points_kind);
    // tf: /tf dynamic, /tf_static static; either may be absent.
    for (const auto& [wanted, role] :
         {std::pair{options_.tf_topic, Role::tf}, std::pair{options_.tf_static_topic, Role::tf_static}}) {
      if (wanted.empty() || find_topic(wanted).empty()) continue;
      const auto [topic, kind] = require_topic(wanted, role == Role::tf ? "tf" : "static tf", {MessageKind::tf});
      add_role(topic, role, kind);
    }
    if (!options_.odom_topic.empty()) {
      const auto [topic, kind] = require_topic(options_.odom_topic, "the odometry topic", {MessageKind::odometry});
      add_role(topic, Role::odometry, kind);
      odom_series_.emplace().topic = topic;
    }
    if (!options_.ground_truth_topic.empty()) {
      const auto [topic, kind] =
          require_topic(options_.ground_truth_topic, "the ground truth topic",
                        {MessageKind::odometry, MessageKind::pose_stamped, MessageKind::pose_with_covariance_stamped});
      add_role(topic, Role::ground_truth, kind);
      truth_.emplace().topic = topic;
    }
    if (!options_.imu_topic.empty()) {
      const auto [topic, kind] = require_topic(options_.imu_topic, "the IMU topic", {MessageKind::imu});
      add_role(topic, Role::imu, kind);
    }
  }

  std::string message_name(const std::string& topic, std::uint64_t ordinal) const {
    return name_ + ": " + shown(topic) + " message " + std::to_string(ordinal);
  }

  void read_messages() {
    store_.read(read_, [&](std::size_t index, std::uint64_t k, MessageBytes& m) {
      const std::string& topic = read_[index];
      const WireFormat format = topics_.at(topic).format;
      const std::string what = message_name(topic, k);
      for (const auto& [role, kind] : roles_[index]) {
        switch (role) {
          case Role::points:
            add_scan(scan_header(format, m, what), k);
            break;
          case Role::tf:
          case Role::tf_static:
            add_transforms(decode_tf(format, m.all(), m.size(), what), role == Role::tf_static, what);
            break;
          case Role::odometry:
            add_pose(*odom_series_, decode_pose(kind, format, m.all(), m.size(), what), what);
            break;
          case Role::ground_truth:
            add_pose(*truth_, decode_pose(kind, format, m.all(), m.size(), what), what);
            break;
          case Role::imu: {
            const msg::Imu imu = decode_imu(format, m.all(), m.size(), what);
            imu_.push_back({imu.header.stamp(), imu.header.frame_id, imu.linear_acceleration});
            break;
          }
        }
      }
    });
  }

  static msg::Header scan_header(WireFormat format, MessageBytes& m, const std::string& what) {
    const std::size_t prefix = std::min(kHeaderPrefix, m.size());
    try {
      return decode_header(format, m.head(prefix), prefix, what);
    } catch (const Error&) {
      if (prefix == m.size()) throw;
      return decode_header(format, m.all(), m.size(), what);  // a frame_id longer than the prefix
    }
  }

  void add_scan(const msg::Header& h, std::uint64_t k) {
    if (k == 0) {
      cloud_frame_ = h.frame_id;
    } else if (h.frame_id != cloud_frame_) {
      throw Error(message_name(out_.points_topic, k) + " is in frame " + quoted_name(h.frame_id) +
                  ", the first scan in " + quoted_name(cloud_frame_));
    }
    const double t = h.stamp();
    if (!stamps_.empty() && !(t > stamps_.back())) {
      throw Error("bag " + name_ + ": scans out of order on " + out_.points_topic + ": scan " + std::to_string(k) +
                  " is stamped " + seconds(t) + " s, not after scan " + std::to_string(k - 1) + " (" +
                  seconds(stamps_.back()) + " s)");
    }
    stamps_.push_back(t);
  }

  void add_transforms(const std::vector<msg::TransformStamped>& transforms, bool is_static, const std::string& what) {
    for (const msg::TransformStamped& t : transforms) {
      try {
        tree_.add(t.header.frame_id, t.child_frame_id, t.header.stamp(), t.transform, is_static);
      } catch (const Error& e) {
        throw Error(what + ": " + e.what());
      }
    }
  }

  void add_pose(PoseSeries& series, const msg::PoseMessage& m, const std::string& what) const {
    const std::string child = m.child_frame_id.empty() ? options_.base_frame : m.child_frame_id;
    if (m.header.frame_id.empty()) throw Error(what + ": empty header.frame_id");
    if (series.samples.empty()) {
      series.parent = m.header.frame_id;
      series.child = child;
    } else if (m.header.frame_id != series.parent || child != series.child) {
      throw Error(what + " is " + quoted_name(m.header.frame_id) + " -> " + quoted_name(child) +
                  ", the first message " + quoted_name(series.parent) + " -> " + quoted_name(series.child));
    }
    series.samples.emplace_back(m.header.stamp(), m.pose);
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
    if (odom_series_) {
      odometry_note_ = "odometry from " + odom_series_->topic + " (" + quoted_name(odom_series_->parent) + " -> " +
                       quoted_name(odom_series_->child) + ")";
    } else if (tree_.has_frame(options_.odom_frame)) {
      odom_from_tf_ = true;
      odometry_note_ =
          "odometry from tf " + quoted_name(options_.odom_frame) + " -> " + quoted_name(options_.base_frame);
    } else {
      out_.missing_odometry = "bag " + name_ + " has no odometry: no tf frame " + quoted_name(options_.odom_frame) +
                              " (--odom_frame) and no --odom_topic";
    }
    if (!truth_) out_.missing_poses = "bag " + name_ + " has no ground truth (--ground_truth_topic)";
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
      for (const std::optional<PoseSeries>* series : {&odom_series_, &truth_}) {
        if (!*series) continue;
        narrow({(*series)->samples.front().first, (*series)->samples.back().first});
        narrow(tree_.coverage((*series)->child, cloud_frame_));
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

  void place_imu() {
    // IMU: specific force rotated into the clouds' frame.
    if (options_.imu_topic.empty()) return;
    std::size_t outside = 0;
    std::map<std::string, std::pair<double, double>> cover;  // per IMU frame, where tf reaches the clouds' frame
    for (const ImuMessage& m : imu_) {
      const std::string frame = m.frame.empty() ? cloud_frame_ : m.frame;
      if (frame != cloud_frame_) needs_cloud_frame("the IMU");
      try {
        auto it = cover.find(frame);
        if (it == cover.end()) it = cover.emplace(frame, tree_.coverage(cloud_frame_, frame)).first;
        if (m.time < it->second.first - 1e-9 || m.time > it->second.second + 1e-9) {
          ++outside;
          continue;
        }
        out_.imu.push_back({m.time, tree_.lookup(cloud_frame_, frame, m.time).linear() * m.acceleration});
      } catch (const Error& e) {
        throw tf_error(e);
      }
    }
    std::stable_sort(out_.imu.begin(), out_.imu.end(),
                     [](const ImuSample& a, const ImuSample& b) { return a.time < b.time; });
    imu_note_ = "; " + std::to_string(out_.imu.size()) + " IMU samples from " + find_topic(options_.imu_topic);
    if (outside > 0) imu_note_ += " (" + std::to_string(outside) + " outside the tf to the clouds' frame left out)";
  }

  void summarize() {
    out_.summary = "bag " + name_ + ": " + std::to_string(out_.times.size()) + " scans on " + out_.points_topic +
                   " (frame " + quoted_name(cloud_frame_) + ", " + seconds(out_.times.front()) + ".." +
                   seconds(out_.times.back()) + " s); " + (odometry_note_.empty() ? "no odometry" : odometry_note_) +
                   "; " +
                   (truth_ ? "ground truth from " + truth_->topic + " (" + quoted_name(truth_->parent) + " -> " +
                                 quoted_name(truth_->child) + ")"
                           : "no ground truth") +
                   imu_note_;
    if (before_ + after_ > 0) {
      out_.summary += "; left out " + std::to_string(before_) + " scans before and " + std::to_string(after_) +
                      " after the odometry / ground truth";
    }
    out_.summary += store_.notes();
  }

  MessageStore& store_;
  const BagOptions& options_;
  const std::string name_;
  const std::map<std::string, TopicInfo>& topics_;
  WireFormat names_format_ = WireFormat::ros1;  // the type names errors list for a topic the bag lacks
  std::vector<std::string> read_;               // the topics read, and
  std::vector<std::vector<std::pair<Role, MessageKind>>> roles_;  // what each is read for
  BagContents out_;
  std::vector<double> stamps_;  // every scan's header stamp, in the bag's order
  std::string cloud_frame_;
  TransformTree tree_;
  std::optional<PoseSeries> odom_series_;  // odometry from a topic, or
  bool odom_from_tf_ = false;              // from tf
  std::string odometry_note_, imu_note_;
  std::optional<PoseSeries> truth_;
  std::vector<ImuMessage> imu_;
  std::size_t before_ = 0, after_ = 0;  // scans left out before and after the odometry / ground truth
};

}  // namespace

BagContents read_contents(MessageStore& store, const BagOptions& options) {
  return ContentsReader(store, options).read();
}

}  // namespace tsdf_mcl::bag_io
