#pragma once
// A rosbag2 folder's metadata.yaml (rosbag2_storage's yaml.hpp): what the reader needs of it, and the file as the
// writer writes it, version 5 (what Humble writes; every later rosbag2 reads it).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace tsdf_mcl::rosbag2 {

struct Metadata {
  std::string storage_identifier;                    // "sqlite3", "mcap"
  std::vector<std::string> relative_file_paths;      // the storage files, in order
  std::string compression_format, compression_mode;  // "zstd", "FILE" / "MESSAGE"; "" for none
};
// Throws Error naming the file: unreadable, not YAML, no rosbag2_bagfile_information, fields of the wrong kind.
Metadata read_metadata(const std::filesystem::path& file);

// For the writer.
struct TopicRecord {
  std::string name, type;
  bool transient_local = false;  // offered durability: /tf_static's, latched
  std::uint64_t messages = 0;
};
struct FileRecord {
  std::string path;  // relative to the folder
  std::int64_t start_ns = 0, end_ns = 0;
  std::uint64_t messages = 0;
};
std::string metadata_yaml(const std::string& storage_identifier, const std::vector<FileRecord>& files,
                          const std::vector<TopicRecord>& topics);
// A topic's offered_qos_profiles as rosbag2 versions 4 to 8 store them: a YAML list of one publisher's QoS (reliable,
// keep-all history unknown, durability volatile or transient_local, infinite deadlines).
std::string offered_qos_profiles(bool transient_local);

}  // namespace tsdf_mcl::rosbag2
