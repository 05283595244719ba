// Reading rosbag2's SQLite3 storage (rosbag2_storage_sqlite3; every schema version from Foxy's to Jazzy's) through
// Debian's libsqlite3, read-only:
//
//   topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, serialization_format TEXT, ...)
//   messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB)
//
// Messages are visited as rosbag2 plays them: by timestamp, then id. Their bytes are read through SQLite's
// incremental blob I/O, so a scan's header costs a few pages, not the whole cloud. A database file is hostile input
// like any other: it is opened read-only in SQLite's defensive mode, without trusting its schema (its two tables
// must be tables, not views), and a corrupt or locked file is one sentence.
#include <sqlite3.h>

#include <algorithm>
#include <map>

#include "storage_file.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::rosbag2 {
namespace fs = std::filesystem;

namespace {

class SqliteFile : public StorageFile {
 public:
  explicit SqliteFile(const fs::path& file) : name_(file.string()) {
    try {
      open(file);
    } catch (...) {
      close();
      throw;
    }
  }

  ~SqliteFile() override { close(); }

  const std::vector<StoredTopic>& topics() const override { return topics_; }

  void read(const std::vector<bool>& wanted, const Visitor& f) override {
    std::string ids;
    for (const auto& [id, index] : topic_index_) {
      if (wanted[index]) ids += (ids.empty() ? "" : ",") + std::to_string(id);
    }
    if (ids.empty()) return;
    Statement rows(*this, "SELECT id, topic_id, length(data) FROM messages WHERE topic_id IN (" + ids +
                              ") ORDER BY timestamp, id");
    while (rows.step()) {
      const sqlite3_int64 id = sqlite3_column_int64(rows.get(), 0);
      const std::size_t topic = topic_index_.at(sqlite3_column_int64(rows.get(), 1));
      Blob message(*this, id,
                   static_cast<std::size_t>(std::max<sqlite3_int64>(0, sqlite3_column_int64(rows.get(), 2))));
      f(topic, Locator{static_cast<std::uint64_t>(id), 0}, message);
    }
  }

  void load(const Locator& at, std::vector<std::uint8_t>& out) override {
    open_blob(static_cast<sqlite3_int64>(at.a));
    out.resize(static_cast<std::size_t>(sqlite3_blob_bytes(blob_)));
    read_blob(out.data(), out.size());
  }

 private:
  // A prepared statement, stepped row by row.
  class Statement {
   public:
    Statement(SqliteFile& file, const std::string& sql) : file_(file) {
      file.check(sqlite3_prepare_v2(file.db_, sql.c_str(), -1, &statement_, nullptr), "reading it");
    }
    ~Statement() { sqlite3_finalize(statement_); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;
    bool step() {
      const int rc = sqlite3_step(statement_);
      if (rc == SQLITE_ROW) return true;
      if (rc != SQLITE_DONE) file_.check(rc, "reading it");
      return false;
    }
    std::string text(int column) const {
      const unsigned char* t = sqlite3_column_text(statement_, column);
      return t ? std::string(reinterpret_cast<const char*>(t),
                             static_cast<std::size_t>(sqlite3_column_bytes(statement_, column)))
               : std::string();
    }
    sqlite3_stmt* get() const { return statement_; }

   private:
    SqliteFile& file_;
    sqlite3_stmt* statement_ = nullptr;
  };

  // A message's data blob, its bytes read as far as asked.
  class Blob : public bag_io::MessageBytes {
   public:
    Blob(SqliteFile& file, sqlite3_int64 row, std::size_t size) : file_(file), row_(row), size_(size) {}
    std::size_t size() const override { return size_; }
    const std::uint8_t* head(std::size_t n) override {
      n = std::min(n, size_);
      if (n > read_) {
        file_.open_blob(row_);
        if (static_cast<std::size_t>(sqlite3_blob_bytes(file_.blob_)) != size_) {
          throw Error(file_.name_ + ": message " + std::to_string(row_) + " changed while it was read");
        }
        file_.buffer_.resize(n);
        file_.read_blob(file_.buffer_.data(), n);
        read_ = n;
      }
      return file_.buffer_.data();
    }

   private:
    SqliteFile& file_;
    sqlite3_int64 row_;
    std::size_t size_, read_ = 0;
  };

  // One sentence for what SQLite says: a locked database (still being recorded), a corrupt one, or else.
  void check(int rc, const char* doing) const {
    if (rc == SQLITE_OK || rc == SQLITE_ROW || rc == SQLITE_DONE) return;
    const int primary = rc & 0xFF;
    const std::string says = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    if (primary == SQLITE_BUSY || primary == SQLITE_LOCKED) {
      throw Error(name_ + ": the SQLite3 database is locked by another process (still being recorded?)");
    }
    if (primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB) {
      throw Error(name_ + ": corrupt SQLite3 database (sqlite3: " + says + ")");
    }
    throw Error(name_ + ": SQLite3 failed " + doing + " (sqlite3: " + says + ")");
  }

  void execute(const char* sql) { check(sqlite3_exec(db_, sql, nullptr, nullptr, nullptr), "opening it"); }

  void check_tables() {
    Statement tables(*this, "SELECT name, type FROM sqlite_master WHERE name IN ('topics', 'messages')");
    int found = 0;
    while (tables.step()) {
      if (tables.text(1) != "table") {
        throw Error(name_ + ": not a rosbag2 SQLite3 file (its '" + tables.text(0) + "' is a " + tables.text(1) +
                    ", not a table)");
      }
      ++found;
    }
    if (found != 2) throw Error(name_ + ": not a rosbag2 SQLite3 file (no tables 'topics' and 'messages')");
  }

  void open(const fs::path& file) {
    // A hostile file must not get SQLite to write, map or run anything: read-only, no mmap, defensive mode.
    check(sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr), "opening it");
    sqlite3_db_config(db_, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
    sqlite3_db_config(db_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
    execute("PRAGMA cell_size_check = ON");
    execute("PRAGMA mmap_size = 0");
    check_tables();
    Statement topics(*this, "SELECT id, name, type, serialization_format FROM topics ORDER BY id");
    while (topics.step()) {
      topic_index_[sqlite3_column_int64(topics.get(), 0)] = topics_.size();
      topics_.push_back({topics.text(1), topics.text(2), topics.text(3)});
    }
  }

  void close() {
    if (blob_) sqlite3_blob_close(blob_);
    blob_ = nullptr;
    sqlite3_close(db_);
    db_ = nullptr;
  }

  void open_blob(sqlite3_int64 row) {
    const int rc =
        blob_ ? sqlite3_blob_reopen(blob_, row) : sqlite3_blob_open(db_, "main", "messages", "data", row, 0, &blob_);
    if (rc != SQLITE_OK && blob_) {  // a handle that failed to move is aborted: it must go
      sqlite3_blob_close(blob_);
      blob_ = nullptr;
    }
    check(rc, "reading a message");
  }

  void read_blob(std::uint8_t* out, std::size_t n) {
    check(sqlite3_blob_read(blob_, out, static_cast<int>(n), 0), "reading a message");
  }

  std::string name_;
  sqlite3* db_ = nullptr;
  sqlite3_blob* blob_ = nullptr;  // the message read last, reopened row by row
  std::vector<std::uint8_t> buffer_;
  std::vector<StoredTopic> topics_;
  std::map<sqlite3_int64, std::size_t> topic_index_;  // topics.id -> index in topics_
};

}  // namespace

std::unique_ptr<StorageFile> open_sqlite_file(const fs::path& file) { return std::make_unique<SqliteFile>(file); }

}  // namespace tsdf_mcl::rosbag2
