// Reading MCAP files (mcap_format.hpp) as rosbag2 writes them, and as any writer of the specification may: chunked
// or not, chunks uncompressed or compressed with zstd or lz4, with or without the summary section and the message
// indexes. The data section is always read as a stream from its start (the index is not needed to visit every
// message once); the summary, where the footer points to one, only gives the channels up front.
//
// Records are read with pread into buffers kept from one record to the next, not through a memory map: mapping a
// bag of gigabytes costs a page fault per 4 KiB read, which measured slower than the copy.
//
// A file that ends inside a record, before its data end, is a recording cut off by a crash: it is read up to its
// last complete record and notes() says where it was cut. Everything else that does not fit (a record running past
// its chunk, a CRC or a length that disagrees, an opcode of 0) is an Error naming the byte.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <unordered_set>

#include "compression.hpp"
#include "mcap_format.hpp"
#include "storage_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl::rosbag2 {
namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kNotInChunk = ~std::uint64_t{0};
// A record other than a chunk is read whole only up to this size (schemas, channels, messages outside chunks).
constexpr std::uint64_t kMaxRecordBytes = limits::kMaxBagMessageBytes + 64;

// The file, read at offsets.
class File {
 public:
  explicit File(const fs::path& file) : name_(file.string()) {
    fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw Error("cannot open " + name_ + ": " + std::strerror(errno));
    const off_t size = ::lseek(fd_, 0, SEEK_END);
    if (size < 0) {
      ::close(fd_);
      throw Error("cannot read " + name_ + ": " + std::strerror(errno));
    }
    size_ = static_cast<std::uint64_t>(size);
  }
  ~File() { ::close(fd_); }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  std::uint64_t size() const { return size_; }

  // n bytes at `offset` into the start of `out`, which only ever grows (zeroing what it grows by costs a pass over
  // it); throws where the file no longer holds them.
  const std::uint8_t* read(std::uint64_t offset, std::uint64_t n, std::vector<std::uint8_t>& out) const {
    if (out.size() < n) out.resize(static_cast<std::size_t>(n));
    std::uint64_t done = 0;
    while (done < n) {
      const ssize_t got =
          ::pread(fd_, out.data() + done, static_cast<std::size_t>(n - done), static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0)
        throw Error("cannot read " + name_ + " at byte " + std::to_string(offset + done) + " (it changed?)");
      done += static_cast<std::uint64_t>(got);
    }
    return out.data();
  }

 private:
  std::string name_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

struct Channel {
  std::uint16_t schema_id = 0;
  std::string topic, encoding;
  std::size_t topic_index = 0;
};

struct Schema {
  std::string name, encoding;
};

// One record as the walk hands it out: where it lies (the chunk's offset in the file, or kNotInChunk; its offset
// in the chunk's records or in the file) and its content.
struct Record {
  std::uint8_t opcode;
  const std::uint8_t* content;
  std::uint64_t size;
  Locator at;
};

class McapFile : public StorageFile {
 public:
  explicit McapFile(const fs::path& file) : name_(file.string()), file_(file) {
    const std::uint64_t n = file_.size();
    constexpr std::size_t kHeaderAt = mcap::kMagicBytes;
    const std::uint8_t* head = n >= kHeaderAt + mcap::kRecordHeaderBytes
                                   ? file_.read(0, kHeaderAt + mcap::kRecordHeaderBytes, record_)
                                   : nullptr;
    if (!head || std::memcmp(head, mcap::kMagic, mcap::kMagicBytes) != 0 || head[kHeaderAt] != mcap::kHeader ||
        io::load<std::uint64_t>(head + kHeaderAt + 1, true) > n - kHeaderAt - mcap::kRecordHeaderBytes) {
      throw Error(name_ + ": truncated or corrupt MCAP file (" + std::to_string(n) +
                  " bytes: no header record after the magic)");
    }
    if (!read_summary()) walk([&](const Record& r) { define(r); });
  }

  const std::vector<StoredTopic>& topics() const override { return topics_; }

  void read(const std::vector<bool>& wanted, const Visitor& f) override {
    walk([&](const Record& r) {
      if (r.opcode != mcap::kMessage) {
        define(r);
        return;
      }
      mcap::FieldReader fields(r.content, r.size, name_);
      const auto channel = channels_.find(fields.value<std::uint16_t>("channel_id"));
      if (channel == channels_.end()) {
        throw Error(name_ + ": corrupt MCAP: a message at byte " + where(r.at) + " on a channel no record defines");
      }
      if (!wanted[channel->second.topic_index]) return;
      fields.bytes(4 + 8 + 8, "sequence, log_time and publish_time");
      const auto [data, size] = fields.rest();
      bag_io::MessageInMemory message(data, static_cast<std::size_t>(size));
      f(channel->second.topic_index, r.at, message);
    });
  }

  void load(const Locator& at, std::vector<std::uint8_t>& out) override {
    const std::uint8_t* record = nullptr;
    std::uint64_t length = 0;
    if (at.a != kNotInChunk) {
      open_chunk(at.a);
      if (at.b > chunk_size_ || chunk_size_ - at.b < mcap::kRecordHeaderBytes) throw changed(at);
      record = chunk_ + at.b;
      length = io::load<std::uint64_t>(record + 1, true);
      if (length > chunk_size_ - at.b - mcap::kRecordHeaderBytes) throw changed(at);
    } else {
      if (at.b > file_.size() || file_.size() - at.b < mcap::kRecordHeaderBytes) throw changed(at);
      length = io::load<std::uint64_t>(file_.read(at.b, mcap::kRecordHeaderBytes, record_) + 1, true);
      if (length > std::min(kMaxRecordBytes, file_.size() - at.b - mcap::kRecordHeaderBytes)) throw changed(at);
      record = file_.read(at.b, mcap::kRecordHeaderBytes + length, record_);
    }
    if (record[0] != mcap::kMessage) throw changed(at);
    mcap::FieldReader fields(record + mcap::kRecordHeaderBytes, length, name_);
    fields.bytes(2 + 4 + 8 + 8, "channel_id, sequence, log_time and publish_time");
    const auto [data, n] = fields.rest();
    out.assign(data, data + n);
  }

  std::string notes() const override { return cut_note_; }

 private:
  std::string where(const Locator& at) const {
    return at.a == kNotInChunk ? std::to_string(at.b)
                               : std::to_string(at.b) + " of the chunk at byte " + std::to_string(at.a);
  }
  Error changed(const Locator& at) const {
    return Error(name_ + ": the message at byte " + where(at) + " is no longer there (the file changed?)");
  }

  // Channels and schemas from the summary section, where the footer points to one (with channels in it).
  bool read_summary() {
    const std::uint64_t n = file_.size();
    constexpr std::uint64_t kFooterRecord = mcap::kRecordHeaderBytes + mcap::kFooterContentBytes;
    if (n < mcap::kMagicBytes * 2 + kFooterRecord) return false;
    const std::uint64_t footer = n - mcap::kMagicBytes - kFooterRecord;
    const std::uint8_t* tail = file_.read(footer, kFooterRecord + mcap::kMagicBytes, record_);
    if (std::memcmp(tail + kFooterRecord, mcap::kMagic, mcap::kMagicBytes) != 0 || tail[0] != mcap::kFooter ||
        io::load<std::uint64_t>(tail + 1, true) != mcap::kFooterContentBytes) {
      return false;  // no footer: a recording cut off, read as a stream
    }
    mcap::FieldReader fields(tail + mcap::kRecordHeaderBytes, mcap::kFooterContentBytes, name_);
    const auto start = fields.value<std::uint64_t>("summary_start");
    const auto offsets = fields.value<std::uint64_t>("summary_offset_start");
    const auto crc = fields.value<std::uint32_t>("summary_crc");
    if (start == 0) return false;
    const std::uint64_t end = offsets != 0 ? offsets : footer;
    if (start < mcap::kMagicBytes || start > end || end > footer || footer - start > limits::kMaxMcapChunkBytes) {
      throw Error(name_ + ": corrupt MCAP: its footer places the summary at bytes " + std::to_string(start) + ".." +
                  std::to_string(end) + ", outside the file or larger than " +
                  std::to_string(limits::kMaxMcapChunkBytes));
    }
    // The summary and the summary offsets, up to and including the footer's summary_offset_start: what its CRC covers.
    std::vector<std::uint8_t> summary;
    const std::uint64_t covered = footer + mcap::kRecordHeaderBytes + 16 - start;
    file_.read(start, covered, summary);
    const std::uint32_t actual = crc32_of(summary.data(), covered);
    if (crc != 0 && actual != crc) {
      throw Error(name_ + ": corrupt MCAP: the summary's CRC is " + std::to_string(actual) + ", the footer says " +
                  std::to_string(crc));
    }
    // Schemas first: the specification groups summary records by opcode but does not order the groups.
    for (const std::uint8_t opcode : {mcap::kSchema, mcap::kChannel}) {
      walk_records(summary.data(), 0, end - start, start, true, [&](const Record& r) {
        if (r.opcode == opcode) define(r);
      });
    }
    return !channels_.empty();
  }

  // Schema and Channel records: what the messages are. A channel's topic gets its index in topics_.
  void define(const Record& r) {
    if (r.opcode == mcap::kSchema) {
      mcap::FieldReader fields(r.content, r.size, name_);
      const auto id = fields.value<std::uint16_t>("schema id");
      Schema s;
      s.name = fields.string("schema name");
      s.encoding = fields.string("schema encoding");
      if (id != 0) schemas_[id] = std::move(s);  // id 0 is invalid: ignored, as the specification says
    } else if (r.opcode == mcap::kChannel) {
      mcap::FieldReader fields(r.content, r.size, name_);
      const auto id = fields.value<std::uint16_t>("channel id");
      Channel c;
      c.schema_id = fields.value<std::uint16_t>("schema_id");
      c.topic = fields.string("topic");
      c.encoding = fields.string("message_encoding");
      add_channel(id, std::move(c));
    }
  }

  void add_channel(std::uint16_t id, Channel c) {
    const auto schema = schemas_.find(c.schema_id);
    const std::string type = schema == schemas_.end() ? "" : schema->second.name;
    const auto known = channels_.find(id);
    if (known != channels_.end()) {
      if (known->second.topic != c.topic || known->second.encoding != c.encoding ||
          topics_[known->second.topic_index].type != type) {
        throw Error(name_ + ": corrupt MCAP: channel " + std::to_string(id) + " is defined twice, differently");
      }
      return;
    }
    auto topic = topic_index_.find(c.topic);
    if (topic == topic_index_.end()) {
      topic = topic_index_.emplace(c.topic, topics_.size()).first;
      topics_.push_back({c.topic, type, c.encoding});
    } else if (topics_[topic->second].type != type || topics_[topic->second].encoding != c.encoding) {
      throw Error(name_ + ": topic " + msg::printable_name(c.topic) + " carries two types, " +
                  msg::printable_name(topics_[topic->second].type) + " and " + msg::printable_name(type));
    }
    c.topic_index = topic->second;
    channels_.emplace(id, std::move(c));
  }

  // Every record of the data section, those inside chunks included, in the file's order. Records the walk does not
  // use (indexes, attachments, metadata, private ones) are skipped unread.
  template <typename F>
  void walk(F&& f) {
    const std::uint64_t n = file_.size();
    std::uint64_t pos = mcap::kMagicBytes;
    cut_note_.clear();
    while (pos < n) {
      std::uint64_t length = ~std::uint64_t{0};
      std::uint8_t opcode = 0;
      if (n - pos >= mcap::kRecordHeaderBytes) {
        const std::uint8_t* header = file_.read(pos, mcap::kRecordHeaderBytes, record_);
        opcode = header[0];
        length = io::load<std::uint64_t>(header + 1, true);
      }
      if (length > n - pos - std::min<std::uint64_t>(n - pos, mcap::kRecordHeaderBytes)) {
        cut_note_ = "; " + name_ + " ends inside a record at byte " + std::to_string(pos) +
                    " (a recording cut off?): read up to there";
        return;
      }
      if (opcode == 0) throw Error(name_ + ": corrupt MCAP: a record of opcode 0 at byte " + std::to_string(pos));
      if (opcode == mcap::kDataEnd || opcode == mcap::kFooter) return;  // the summary is not needed
      if (opcode == mcap::kChunk) {
        open_chunk(pos);
        walk_records(chunk_, 0, chunk_size_, pos, false, f);
      } else if (opcode == mcap::kSchema || opcode == mcap::kChannel || opcode == mcap::kMessage) {
        if (length > kMaxRecordBytes) {
          throw Error(name_ + ": the record at byte " + std::to_string(pos) + " holds " + std::to_string(length) +
                      " bytes, more than the limit of " + std::to_string(kMaxRecordBytes));
        }
        const std::uint8_t* record = file_.read(pos, mcap::kRecordHeaderBytes + length, record_);
        f(Record{opcode, record + mcap::kRecordHeaderBytes, length, {kNotInChunk, pos}});
      }
      pos += mcap::kRecordHeaderBytes + length;
    }
    cut_note_ = "; " + name_ + " ends without its data end (a recording cut off?)";
  }

  // The records in [begin, end) of `base`, which must fill it exactly; `at` is where base lies (a chunk's offset,
  // or for the summary where it starts in the file).
  template <typename F>
  void walk_records(const std::uint8_t* base, std::uint64_t begin, std::uint64_t end, std::uint64_t at, bool summary,
                    F&& f) const {
    for (std::uint64_t pos = begin; pos < end;) {
      const std::uint64_t length =
          end - pos >= mcap::kRecordHeaderBytes ? io::load<std::uint64_t>(base + pos + 1, true) : ~std::uint64_t{0};
      const Locator where_it_is = summary ? Locator{kNotInChunk, at + pos} : Locator{at, pos};
      if (length > end - pos - std::min<std::uint64_t>(end - pos, mcap::kRecordHeaderBytes)) {
        throw Error(name_ + ": corrupt MCAP: the record at byte " + where(where_it_is) + " runs past the end of its " +
                    (summary ? "summary section" : "chunk"));
      }
      if (base[pos] == 0) throw Error(name_ + ": corrupt MCAP: a record of opcode 0 at byte " + where(where_it_is));
      f(Record{base[pos], base + pos + mcap::kRecordHeaderBytes, length, where_it_is});
      pos += mcap::kRecordHeaderBytes + length;
    }
  }

  // Makes chunk_ the records of the chunk record at `offset`, decompressed, its CRC checked the first time it is
  // opened (the walk that opens the bag sees every chunk; loading a scan later opens it again).
  void open_chunk(std::uint64_t offset) {
    if (offset == chunk_offset_) return;
    chunk_offset_ = kNotInChunk;
    const std::string what = name_ + ": the chunk at byte " + std::to_string(offset);
    const std::uint64_t n = file_.size();
    if (offset > n || n - offset < mcap::kRecordHeaderBytes)
      throw Error(what + " is no longer there (the file changed?)");
    const std::uint8_t* header = file_.read(offset, mcap::kRecordHeaderBytes, chunk_record_);
    const std::uint64_t length = io::load<std::uint64_t>(header + 1, true);
    if (header[0] != mcap::kChunk || length > n - offset - mcap::kRecordHeaderBytes) {
      throw Error(what + " is no longer there (the file changed?)");
    }
    if (length > limits::kMaxMcapChunkBytes + 1024) {
      throw Error(what + " holds " + std::to_string(length) + " bytes, more than the limit of " +
                  std::to_string(limits::kMaxMcapChunkBytes));
    }
    const std::uint8_t* content = file_.read(offset + mcap::kRecordHeaderBytes, length, chunk_record_);
    mcap::FieldReader fields(content, length, what);
    fields.bytes(16, "message_start_time and message_end_time");
    const auto uncompressed_size = fields.value<std::uint64_t>("uncompressed_size");
    const auto crc = fields.value<std::uint32_t>("uncompressed_crc");
    const std::string compression = fields.string("compression");
    const auto [records, size] = fields.bytes(fields.value<std::uint64_t>("records length"), "records");
    if (uncompressed_size > limits::kMaxMcapChunkBytes) {
      throw Error(what + " holds " + std::to_string(uncompressed_size) + " bytes, more than the limit of " +
                  std::to_string(limits::kMaxMcapChunkBytes));
    }
    if (compression.empty()) {
      if (size != uncompressed_size) {
        throw Error(what + ": corrupt MCAP: " + std::to_string(size) + " bytes of uncompressed records, " +
                    std::to_string(uncompressed_size) + " declared");
      }
      chunk_ = records;
    } else {
      decompress(compression, records, static_cast<std::size_t>(size), uncompressed_size, buffer_, what);
      chunk_ = buffer_.data();
    }
    chunk_size_ = uncompressed_size;
    if (crc != 0 && checked_.count(offset) == 0) {
      const std::uint32_t actual = crc32_of(chunk_, chunk_size_);
      if (actual != crc) {
        throw Error(what + ": CRC mismatch: its records' CRC-32 is " + std::to_string(actual) + ", the chunk says " +
                    std::to_string(crc));
      }
      checked_.insert(offset);
    }
    chunk_offset_ = offset;
  }

  std::string name_;
  File file_;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<StoredTopic> topics_;
  std::map<std::string, std::size_t> topic_index_;
  std::string cut_note_;
  std::vector<std::uint8_t> record_;  // the record read last outside a chunk
  // The chunk opened last: its record as read, its records (there, or decompressed into buffer_).
  std::uint64_t chunk_offset_ = kNotInChunk;
  std::vector<std::uint8_t> chunk_record_;
  const std::uint8_t* chunk_ = nullptr;
  std::uint64_t chunk_size_ = 0;
  Decompressed buffer_;
  std::unordered_set<std::uint64_t> checked_;  // the chunks whose CRC matched
};

}  // namespace

std::unique_ptr<StorageFile> open_mcap_file(const fs::path& file) { return std::make_unique<McapFile>(file); }

}  // namespace tsdf_mcl::rosbag2
