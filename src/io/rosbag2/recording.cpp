// A rosbag2 recording as a MessageStore (message_store.hpp): a folder (metadata.yaml and its storage files, split
// bags in order; or, where a crash left no metadata.yaml, the storage files it holds) or one .db3 or .mcap file,
// each file recognized by its content. Then the one dataset code path (contents_reader.hpp) and the scans.
//
// rosbag2's compression: per message (compression_mode message, zstd) is read, each message decompressed as it is
// read (recognized by the zstd frame's magic, where CDR starts with a zero byte); whole files (compression_mode file)
// are refused with the command that decompresses them, and read once decompressed beside.
#include <algorithm>
#include <mutex>

#include "../bag/bag_formats.hpp"
#include "../bag/contents_reader.hpp"
#include "../bag/message_codec.hpp"
#include "compression.hpp"
#include "metadata.hpp"
#include "storage_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl::rosbag2 {
namespace fs = std::filesystem;

namespace {

using bag_io::FileSignature;

[[noreturn]] void refuse_compressed_file(const fs::path& file) {
  throw Error(file.string() + " is zstd-compressed whole (rosbag2 --compression-mode file): 'zstd -d " + file.string() +
              "' decompresses it beside, where tsdf-mcl then reads it");
}

// The number rosbag2 ends a split file's name with (NAME_3.db3: 3), for the order of files without metadata.yaml.
std::uint64_t split_index(const fs::path& file) {
  const std::string stem = file.stem().string();
  const std::size_t underscore = stem.rfind('_');
  const std::string digits = underscore == std::string::npos ? "" : stem.substr(underscore + 1);
  if (digits.empty() || digits.size() > 12 || !std::all_of(digits.begin(), digits.end(), ::isdigit)) return 0;
  return std::stoull(digits);
}

std::unique_ptr<StorageFile> open_storage(const fs::path& file) {
  switch (bag_io::file_signature(file)) {
    case FileSignature::sqlite3:
      return open_sqlite_file(file);
    case FileSignature::mcap:
      return open_mcap_file(file);
    case FileSignature::zstd:
      refuse_compressed_file(file);
    default:
      throw Error(file.string() + " is neither a rosbag2 SQLite3 nor an MCAP file");
  }
}

class Recording : public bag_io::MessageStore {
 public:
  struct Place {
    std::size_t file;
    Locator at;
  };

  explicit Recording(const fs::path& path) : name_(path.string()) {
    for (const fs::path& file : storage_files(path)) {
      files_.push_back(open_storage(file));
      add_topics(*files_.back(), file);
    }
  }

  const std::string& name() const override { return name_; }
  const std::map<std::string, bag_io::TopicInfo>& topics() const override { return topics_; }
  std::string notes() const override {
    std::string out = notes_;
    for (const auto& f : files_) out += f->notes();
    return out;
  }

  void read(const std::vector<std::string>& topics, const Visitor& f) override {
    std::vector<std::uint64_t> ordinals(topics.size(), 0);
    places_.assign(topics.size(), {});
    read_ = topics;
    for (std::size_t k = 0; k < files_.size(); ++k) {
      // Per topic of this file: its index in `topics`, or topics.size().
      std::vector<std::size_t> index;
      std::vector<bool> wanted;
      for (const std::string& name : file_topics_[k]) {
        index.push_back(static_cast<std::size_t>(std::find(topics.begin(), topics.end(), name) - topics.begin()));
        wanted.push_back(index.back() < topics.size());
      }
      files_[k]->read(wanted, [&](std::size_t topic, const Locator& at, bag_io::MessageBytes& message) {
        const std::size_t i = index[topic];
        const std::string what =
            name_ + ": " + msg::printable_name(topics[i]) + " message " + std::to_string(ordinals[i]);
        check_size(message.size(), what);
        places_[i].push_back({k, at});
        if (topics_.at(topics[i]).format == bag_io::WireFormat::cdr && is_zstd_frame(message.head(4), message.size())) {
          decompress_zstd_frame(message.all(), message.size(), limits::kMaxBagMessageBytes, decompressed_, what);
          bag_io::MessageInMemory decompressed(decompressed_.data(), decompressed_.size());
          f(i, ordinals[i]++, decompressed);
        } else {
          f(i, ordinals[i]++, message);
        }
      });
    }
  }

  // Where the messages read on `topic` lie, by ordinal.
  const std::vector<Place>& places(const std::string& topic) const {
    return places_.at(static_cast<std::size_t>(std::find(read_.begin(), read_.end(), topic) - read_.begin()));
  }

  // A message read before, whole (and decompressed, in CDR).
  void load(const Place& p, bag_io::WireFormat format, std::vector<std::uint8_t>& out, const std::string& what) {
    files_.at(p.file)->load(p.at, out);
    check_size(out.size(), what);
    if (format == bag_io::WireFormat::cdr && is_zstd_frame(out.data(), out.size())) {
      decompress_zstd_frame(out.data(), out.size(), limits::kMaxBagMessageBytes, decompressed_, what);
      out.assign(decompressed_.data(), decompressed_.data() + decompressed_.size());
    }
  }

 private:
  static void check_size(std::size_t size, const std::string& what) {
    if (size > limits::kMaxBagMessageBytes) {
      throw Error(what + " has " + std::to_string(size) + " bytes, more than the limit of " +
                  std::to_string(limits::kMaxBagMessageBytes));
    }
  }

  // The storage files of a folder or a file, in order.
  std::vector<fs::path> storage_files(const fs::path& path) {
    std::error_code ec;
    if (!fs::is_directory(path, ec)) {
      switch (bag_io::file_signature(path)) {
        case FileSignature::sqlite3:
        case FileSignature::mcap:
          return {path};
        case FileSignature::zstd:
          refuse_compressed_file(path);
        case FileSignature::rosbag2_metadata:
          return storage_files(path.parent_path().empty() ? fs::path(".") : path.parent_path());
        default:
          throw Error(path.string() +
                      " is not a bag: neither a ROS 1 bag ('#ROSBAG V2.0'), a rosbag2 SQLite3 or MCAP file, nor a "
                      "rosbag2 folder's metadata.yaml");
      }
    }
    if (fs::exists(path / "metadata.yaml", ec)) return files_of_metadata(path);
    // No metadata.yaml (a recording cut off before rosbag2 wrote it): the storage files there, in split order.
    std::vector<fs::path> files;
    for (const fs::directory_entry& e : fs::directory_iterator(path, ec)) {
      if (!e.is_regular_file(ec)) continue;
      const FileSignature s = bag_io::file_signature(e.path());
      if (s == FileSignature::sqlite3 || s == FileSignature::mcap) files.push_back(e.path());
    }
    if (files.empty()) {
      throw Error(path.string() + " is not a rosbag2 folder: no metadata.yaml and no SQLite3 or MCAP file in it");
    }
    std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
      return std::pair(split_index(a), a.filename()) < std::pair(split_index(b), b.filename());
    });
    notes_ = "; no metadata.yaml: read the folder's " + std::to_string(files.size()) + " storage files in order";
    return files;
  }

  std::vector<fs::path> files_of_metadata(const fs::path& folder) {
    const Metadata m = read_metadata(folder / "metadata.yaml");
    if (!m.compression_mode.empty() && m.compression_mode != "NONE" && m.compression_format != "zstd") {
      throw Error(folder.string() + ": compressed with '" + m.compression_format +
                  "', which is not read (rosbag2's zstd is)");
    }
    if (m.relative_file_paths.empty()) throw Error(folder.string() + ": its metadata.yaml lists no storage files");
    std::vector<fs::path> files;
    std::error_code ec;
    for (const std::string& relative : m.relative_file_paths) {
      fs::path file = folder / relative;
      // rosbag2's first compressed bags named the folder in each path too.
      if (!fs::exists(file, ec)) file = folder / fs::path(relative).filename();
      // A whole-file compressed one: read where it was decompressed beside (as `ros2 bag play` leaves it).
      if (file.extension() == ".zstd") {
        if (fs::exists(fs::path(file).replace_extension(), ec)) {
          file.replace_extension();
        } else if (fs::exists(file, ec)) {
          throw Error(folder.string() + ": its storage files are zstd-compressed whole (rosbag2 --compression-mode " +
                      "file): 'zstd -d " + (folder / "*.zstd").string() +
                      "' decompresses them beside, where "
                      "tsdf-mcl then reads them");
        }
      }
      if (!fs::exists(file, ec)) {
        throw Error(folder.string() + ": its metadata.yaml lists " + relative + ", which is not there");
      }
      files.push_back(file);
    }
    if (m.compression_mode == "MESSAGE") notes_ = "; messages zstd-compressed (rosbag2 --compression-mode message)";
    return files;
  }

  void add_topics(const StorageFile& file, const fs::path& path) {
    file_topics_.emplace_back();
    for (const StoredTopic& t : file.topics()) {
      bag_io::TopicInfo info;
      info.type = t.type.empty() ? "(no schema)" : t.type;
      if (t.encoding == "cdr") {
        info.format = bag_io::WireFormat::cdr;
      } else if (t.encoding == "ros1") {
        info.format = bag_io::WireFormat::ros1;  // an MCAP of ROS 1 messages (mcap convert x.bag)
      } else {
        info.type += " in the " + t.encoding + " encoding";  // read as no type of ours
        info.format = bag_io::WireFormat::cdr;
      }
      const auto [it, inserted] = topics_.try_emplace(t.name, info);
      if (!inserted && (it->second.type != info.type || it->second.format != info.format)) {
        throw Error(path.string() + ": topic " + msg::printable_name(t.name) + " carries " +
                    msg::printable_name(info.type) + ", an earlier file " + msg::printable_name(it->second.type));
      }
      file_topics_.back().push_back(t.name);
    }
  }

  std::string name_, notes_;
  std::vector<std::unique_ptr<StorageFile>> files_;
  std::vector<std::vector<std::string>> file_topics_;  // per file, its topics' names by their index there
  std::map<std::string, bag_io::TopicInfo> topics_;
  std::vector<std::string> read_;           // the topics read last, and
  std::vector<std::vector<Place>> places_;  // where each one's messages lie
  Decompressed decompressed_;               // the last message rosbag2 compressed
};

class Rosbag2Scans : public Dataset::ScanSource {
 public:
  Rosbag2Scans(std::shared_ptr<Recording> recording, const std::string& topic,
               const std::vector<std::uint64_t>& ordinals)
      : recording_(std::move(recording)), topic_(topic), format_(recording_->topics().at(topic).format) {
    const std::vector<Recording::Place>& all = recording_->places(topic);
    for (const std::uint64_t k : ordinals) places_.push_back(all.at(k));
  }

  PointCloud load(std::size_t i, std::size_t* dropped_non_finite) const override {
    const std::string what = name(i);
    // One buffer per thread, kept: a fresh megabyte per scan cost more in page faults than the scan's decoding.
    thread_local std::vector<std::uint8_t> bytes;
    {
      const std::lock_guard<std::mutex> lock(mutex_);  // the files read through one chunk cache, one blob handle
      recording_->load(places_.at(i), format_, bytes, what);
    }
    return bag_io::decode_scan(format_, bytes.data(), bytes.size(), what, dropped_non_finite);
  }

  std::string name(std::size_t i) const override {
    return recording_->name() + ":" + topic_ + "[" + std::to_string(i) + "]";
  }

 private:
  std::shared_ptr<Recording> recording_;
  std::string topic_;
  bag_io::WireFormat format_;
  std::vector<Recording::Place> places_;
  mutable std::mutex mutex_;
};

}  // namespace
}  // namespace tsdf_mcl::rosbag2

namespace tsdf_mcl::bag_io {

OpenedBag open_rosbag2(const std::filesystem::path& path, const BagOptions& options) {
  auto recording = std::make_shared<rosbag2::Recording>(path);
  OpenedBag bag;
  bag.contents = read_contents(*recording, options);
  bag.scans = std::make_shared<rosbag2::Rosbag2Scans>(recording, bag.contents.points_topic, bag.contents.scan_ordinals);
  return bag;
}

}  // namespace tsdf_mcl::bag_io
