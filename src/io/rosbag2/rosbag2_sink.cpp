// The rosbag2 sink of BagWriter (bag_writer.hpp): the messages in CDR (ros2_messages.hpp) into one storage file
// (FILE.mcap, FILE.db3) or a folder as `ros2 bag record -o NAME` writes it (NAME/metadata.yaml beside NAME_0.mcap or
// NAME_0.db3, NAME_1... once a file holds split_bytes), written under a .partial name and renamed when complete.
#include <map>
#include <optional>

#include "../bag/bag_formats.hpp"
#include "mcap_writer.hpp"
#include "metadata.hpp"
#include "sqlite_writer.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl::rosbag2 {
namespace fs = std::filesystem;

namespace {

class Rosbag2Sink : public bag_io::BagSink {
 public:
  Rosbag2Sink(const fs::path& path, const BagWriterOptions& options)
      : file_(path.filename().empty() ? path.parent_path() : path), options_(options) {
    const std::string extension = file_.extension().string();
    folder_ = extension != ".mcap" && extension != ".db3";
    mcap_ = folder_ ? options.storage == "mcap" : extension == ".mcap";
    if (folder_ && options.storage != "mcap" && options.storage != "sqlite3") {
      throw Error("unknown rosbag2 storage '" + options.storage + "' (mcap or sqlite3)");
    }
    partial_ = file_.string() + ".partial";
    std::error_code ec;
    if (fs::is_directory(file_, ec)) throw Error("bag " + file_.string() + " already exists (a folder)");
    if (folder_) {
      fs::remove_all(partial_, ec);  // what a failed run left
      if (!fs::create_directory(partial_, ec)) throw Error("cannot create bag folder " + partial_.string());
    }
    open_file();
  }

  ~Rosbag2Sink() override {
    if (finished_) return;
    mcap_writer_.reset();
    sqlite_writer_.reset();
    std::error_code ignored;
    fs::remove_all(partial_, ignored);
  }

  void write_tf(const std::string& topic, double time, const std::vector<msg::TransformStamped>& transforms,
                bool is_static) override {
    write(topic, ros2::kTfMessage, is_static, time, ros2::encode_tf_message(transforms));
  }
  void write_points(const std::string& topic, double time, const msg::Header& header,
                    const EncodedPointCloud2& cloud) override {
    write(topic, ros2::kPointCloud2, false, time, ros2::encode_pointcloud2_message(header, cloud.layout, cloud.data));
  }
  void write_odometry(const std::string& topic, double time, const msg::PoseMessage& odometry) override {
    write(topic, ros2::kOdometry, false, time, ros2::encode_odometry(odometry));
  }
  void write_imu(const std::string& topic, double time, const msg::Imu& imu) override {
    write(topic, ros2::kImu, false, time, ros2::encode_imu(imu));
  }

  void finish() override {
    close_file();
    std::error_code ec;
    if (folder_) {
      write_file_atomically(partial_ / "metadata.yaml",
                            metadata_yaml(mcap_ ? "mcap" : "sqlite3", files_, topic_records()), "bag metadata");
    }
    fs::rename(partial_, file_, ec);
    if (ec) throw Error("cannot rename " + partial_.string() + " to " + file_.string() + ": " + ec.message());
    finished_ = true;
  }

 private:
  struct Topic {
    TopicRecord record;
    std::int64_t id = -1;  // in the open file; -1 before its first message there
  };

  // The storage file being written: the whole bag, or the folder's next one.
  fs::path storage_path() const {
    if (!folder_) return partial_;
    return partial_ / (file_.filename().string() + "_" + std::to_string(files_.size()) + (mcap_ ? ".mcap" : ".db3"));
  }

  void open_file() {
    const fs::path path = storage_path();
    FileRecord record;
    record.path = path.filename().string();
    files_.push_back(record);
    bytes_ = 0;
    for (auto& [name, topic] : topics_) topic.id = -1;
    if (mcap_) {
      mcap_writer_.emplace(path,
                           McapWriter::Options{options_.compression, options_.mcap_summary, options_.mcap_chunk_bytes});
    } else {
      sqlite_writer_.emplace(path);
    }
  }

  void close_file() {
    if (mcap_writer_) mcap_writer_->close();
    if (sqlite_writer_) {
      sqlite_writer_->close(metadata_yaml("sqlite3", {files_.back()}, topic_records()));
    }
    mcap_writer_.reset();
    sqlite_writer_.reset();
  }

  std::vector<TopicRecord> topic_records() const {
    std::vector<TopicRecord> out;
    for (const std::string& name : order_) out.push_back(topics_.at(name).record);
    return out;
  }

  void write(const std::string& name, const char* type, bool transient_local, double time,
             const std::vector<std::uint8_t>& data) {
    const msg::Header stamp = msg::stamp_of(time);  // the encoder checked it fits int32 seconds
    const std::int64_t ns = stamp.sec * 1000000000 + stamp.nsec;
    auto it = topics_.find(name);
    if (it == topics_.end()) {
      it = topics_.emplace(name, Topic{{name, type, transient_local, 0}, -1}).first;
      order_.push_back(name);
    }
    Topic& topic = it->second;
    if (topic.id < 0) {
      const std::string qos = offered_qos_profiles(transient_local);
      topic.id = mcap_ ? mcap_writer_->add_channel(name, type, ros2::message_definition(type), qos)
                       : sqlite_writer_->add_topic(name, type, ros2::message_definition(type), qos);
    }
    if (mcap_) {
      mcap_writer_->write(static_cast<std::uint16_t>(topic.id), static_cast<std::uint64_t>(ns), data);
    } else {
      sqlite_writer_->write(topic.id, ns, data);
    }
    ++topic.record.messages;
    FileRecord& file = files_.back();
    if (file.messages == 0 || ns < file.start_ns) file.start_ns = ns;
    file.end_ns = std::max(file.end_ns, ns);
    ++file.messages;
    bytes_ += data.size();
    if (folder_ && options_.split_bytes > 0 && bytes_ > options_.split_bytes) {
      close_file();
      open_file();
    }
  }

  fs::path file_, partial_;
  BagWriterOptions options_;
  bool folder_ = false, mcap_ = true, finished_ = false;
  std::optional<McapWriter> mcap_writer_;
  std::optional<SqliteWriter> sqlite_writer_;
  std::map<std::string, Topic> topics_;
  std::vector<std::string> order_;  // the topics as they first came
  std::vector<FileRecord> files_;
  std::uint64_t bytes_ = 0;  // messages written to the open file
};

}  // namespace
}  // namespace tsdf_mcl::rosbag2

namespace tsdf_mcl::bag_io {

std::unique_ptr<BagSink> make_rosbag2_sink(const std::filesystem::path& path, const BagWriterOptions& options) {
  return std::make_unique<rosbag2::Rosbag2Sink>(path, options);
}

}  // namespace tsdf_mcl::bag_io
