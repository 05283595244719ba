#pragma once
// Writing rosbag2's SQLite3 storage (rosbag2_storage_sqlite3, schema version 4: Iron's and Jazzy's; Humble reads it
// as its own, the newer columns unused): the schema, metadata, topics, message_definitions and messages tables and
// the timestamp index, in one transaction, as `ros2 bag record -s sqlite3` writes them.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

struct sqlite3;

namespace tsdf_mcl::rosbag2 {

class SqliteWriter {
 public:
  // Throws Error where the database cannot be created.
  explicit SqliteWriter(const std::filesystem::path& file);
  ~SqliteWriter();
  SqliteWriter(const SqliteWriter&) = delete;
  SqliteWriter& operator=(const SqliteWriter&) = delete;

  // A topic (and its type's definition, once per type); returns its id.
  std::int64_t add_topic(const std::string& name, const std::string& type, const std::string& definition,
                         const std::string& offered_qos_profiles);
  void write(std::int64_t topic, std::int64_t time_ns, const std::vector<std::uint8_t>& data);
  // Stores the bag's metadata (metadata.yaml's text) in the metadata table, commits and closes.
  void close(const std::string& metadata);

 private:
  void execute(const std::string& sql);
  [[noreturn]] void fail(const char* doing) const;

  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
  std::vector<std::string> defined_types_;
};

}  // namespace tsdf_mcl::rosbag2
