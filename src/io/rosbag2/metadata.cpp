#include "metadata.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <limits>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/core/input_file.hpp"

namespace tsdf_mcl::rosbag2 {

Metadata read_metadata(const std::filesystem::path& file) {
  const std::string text = read_input_file(file, "rosbag2 metadata", limits::kMaxBagMetadataBytes);
  Metadata m;
  try {
    const YAML::Node root = YAML::Load(text);
    const YAML::Node info = root.IsMap() ? root["rosbag2_bagfile_information"] : YAML::Node();
    if (!info || !info.IsMap()) throw Error(file.string() + ": no rosbag2_bagfile_information (not rosbag2 metadata)");
    if (info["storage_identifier"]) m.storage_identifier = info["storage_identifier"].as<std::string>();
    if (!info["relative_file_paths"] || !info["relative_file_paths"].IsSequence()) {
      throw Error(file.string() + ": no relative_file_paths (the bag's storage files)");
    }
    m.relative_file_paths = info["relative_file_paths"].as<std::vector<std::string>>();
    if (info["compression_format"]) m.compression_format = info["compression_format"].as<std::string>();
    if (info["compression_mode"]) m.compression_mode = info["compression_mode"].as<std::string>();
  } catch (const YAML::Exception& e) {
    throw Error(file.string() + ": not valid rosbag2 metadata (" + e.what() + ")");
  }
  std::transform(m.compression_mode.begin(), m.compression_mode.end(), m.compression_mode.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return m;
}

std::string offered_qos_profiles(bool transient_local) {
  // rmw's enums by number: history 3 unknown, reliability 1 reliable, durability 1 transient_local / 2 volatile,
  // liveliness 1 automatic; RMW_DURATION_INFINITE as rosbag2 writes it.
  const std::string infinite = "\n    sec: 9223372036\n    nsec: 854775807";
  return "- history: 3\n  depth: 0\n  reliability: 1\n  durability: " + std::string(transient_local ? "1" : "2") +
         "\n  deadline:" + infinite + "\n  lifespan:" + infinite +
         "\n  liveliness: 1\n  liveliness_lease_duration:" + infinite + "\n  avoid_ros_namespace_conventions: false";
}

std::string metadata_yaml(const std::string& storage_identifier, const std::vector<FileRecord>& files,
                          const std::vector<TopicRecord>& topics) {
  std::int64_t start = std::numeric_limits<std::int64_t>::max(), end = 0;
  std::uint64_t messages = 0;
  for (const FileRecord& f : files) {
    if (f.messages == 0) continue;
    start = std::min(start, f.start_ns);
    end = std::max(end, f.end_ns);
    messages += f.messages;
  }
  if (messages == 0) start = 0;
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "rosbag2_bagfile_information" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "version" << YAML::Value << 5;
  out << YAML::Key << "storage_identifier" << YAML::Value << storage_identifier;
  out << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds" << YAML::Value
      << end - start << YAML::EndMap;
  out << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds_since_epoch"
      << YAML::Value << start << YAML::EndMap;
  out << YAML::Key << "message_count" << YAML::Value << messages;
  out << YAML::Key << "topics_with_message_count" << YAML::Value << YAML::BeginSeq;
  for (const TopicRecord& t : topics) {
    out << YAML::BeginMap << YAML::Key << "topic_metadata" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << t.name << YAML::Key << "type" << YAML::Value << t.type;
    out << YAML::Key << "serialization_format" << YAML::Value << "cdr";
    out << YAML::Key << "offered_qos_profiles" << YAML::Value << YAML::DoubleQuoted
        << offered_qos_profiles(t.transient_local);
    out << YAML::EndMap << YAML::Key << "message_count" << YAML::Value << t.messages << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "compression_format" << YAML::Value << YAML::DoubleQuoted << "";
  out << YAML::Key << "compression_mode" << YAML::Value << YAML::DoubleQuoted << "";
  out << YAML::Key << "relative_file_paths" << YAML::Value << YAML::BeginSeq;
  for (const FileRecord& f : files) out << f.path;
  out << YAML::EndSeq;
  out << YAML::Key << "files" << YAML::Value << YAML::BeginSeq;
  for (const FileRecord& f : files) {
    out << YAML::BeginMap << YAML::Key << "path" << YAML::Value << f.path;
    out << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds_since_epoch"
        << YAML::Value << (f.messages ? f.start_ns : 0) << YAML::EndMap;
    out << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds" << YAML::Value
        << (f.messages ? f.end_ns - f.start_ns : 0) << YAML::EndMap;
    out << YAML::Key << "message_count" << YAML::Value << f.messages << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace tsdf_mcl::rosbag2
