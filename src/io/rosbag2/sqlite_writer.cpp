#include "sqlite_writer.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <memory>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::rosbag2 {
namespace {

using Statement = std::unique_ptr<sqlite3_stmt, decltype(&sqlite3_finalize)>;

}  // namespace

SqliteWriter::SqliteWriter(const std::filesystem::path& file) : file_(file) {
  if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error("cannot create " + file.string() + ": " + why);
  }
  // rosbag2's defaults for recording: no journal on disk, no sync per transaction.
  execute("PRAGMA journal_mode = MEMORY");
  execute("PRAGMA synchronous = OFF");
  execute("BEGIN");
  execute("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL)");
  execute("INSERT INTO schema (schema_version, ros_distro) VALUES (4, '')");
  execute("CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata TEXT NOT NULL)");
  execute(
      "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,serialization_format "
      "TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL,type_description_hash TEXT NOT NULL)");
  execute(
      "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,encoding TEXT NOT "
      "NULL,encoded_message_definition TEXT NOT NULL,type_description_hash TEXT NOT NULL)");
  execute(
      "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, data "
      "BLOB NOT NULL)");
  execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC)");
}

SqliteWriter::~SqliteWriter() { sqlite3_close(db_); }

void SqliteWriter::execute(const std::string& sql) {
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) fail("writing it");
}

void SqliteWriter::fail(const char* doing) const {
  throw Error("cannot write " + file_.string() + " (" + doing + ": " + sqlite3_errmsg(db_) + ")");
}

std::int64_t SqliteWriter::add_topic(const std::string& name, const std::string& type, const std::string& definition,
                                     const std::string& offered_qos_profiles) {
  const auto bind_texts = [&](const char* sql, std::initializer_list<const std::string*> texts) {
    sqlite3_stmt* raw = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &raw, nullptr) != SQLITE_OK) fail("adding a topic");
    const Statement statement(raw, sqlite3_finalize);
    int column = 1;
    for (const std::string* t : texts) {
      sqlite3_bind_text(raw, column++, t->c_str(), static_cast<int>(t->size()), SQLITE_TRANSIENT);
    }
    if (sqlite3_step(raw) != SQLITE_DONE) fail("adding a topic");
  };
  const std::string cdr = "cdr", ros2msg = "ros2msg", none;
  if (std::find(defined_types_.begin(), defined_types_.end(), type) == defined_types_.end()) {
    bind_texts(
        "INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, "
        "type_description_hash) VALUES (?, ?, ?, ?)",
        {&type, &ros2msg, &definition, &none});
    defined_types_.push_back(type);
  }
  bind_texts(
      "INSERT INTO topics (name, type, serialization_format, offered_qos_profiles, type_description_hash) "
      "VALUES (?, ?, ?, ?, ?)",
      {&name, &type, &cdr, &offered_qos_profiles, &none});
  return sqlite3_last_insert_rowid(db_);
}

void SqliteWriter::write(std::int64_t topic, std::int64_t time_ns, const std::vector<std::uint8_t>& data) {
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db_, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1, &raw, nullptr) !=
      SQLITE_OK) {
    fail("adding a message");
  }
  const Statement statement(raw, sqlite3_finalize);
  sqlite3_bind_int64(raw, 1, topic);
  sqlite3_bind_int64(raw, 2, time_ns);
  sqlite3_bind_blob64(raw, 3, data.data(), data.size(), SQLITE_STATIC);
  if (sqlite3_step(raw) != SQLITE_DONE) fail("adding a message");
}

void SqliteWriter::close(const std::string& metadata) {
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db_, "INSERT INTO metadata (metadata_version, metadata) VALUES (5, ?)", -1, &raw, nullptr) !=
      SQLITE_OK) {
    fail("adding its metadata");
  }
  {
    const Statement statement(raw, sqlite3_finalize);
    sqlite3_bind_text(raw, 1, metadata.c_str(), static_cast<int>(metadata.size()), SQLITE_STATIC);
    if (sqlite3_step(raw) != SQLITE_DONE) fail("adding its metadata");
  }
  execute("COMMIT");
  if (sqlite3_close(db_) != SQLITE_OK) fail("closing it");
  db_ = nullptr;
}

}  // namespace tsdf_mcl::rosbag2
