// Reading MCAP files (mcap_format.hpp) as rosbag2 writes them, and as any writer of the specification may: chunked
// or not, chunks uncompressed or compressed with zstd or lz4, with or without the summary section and the message
// indexes. The data section is always read as a stream from its start (the index is not needed to visit every
// message once); the summary, where the footer points to one, only gives the channels up front.
//
// A file that ends inside a record, before its data end, is a recording cut off by a crash: it is read up to its
// last complete record and notes() says where it was cut. Everything else that does not fit (a record running past
// its chunk, a CRC or a length that disagrees, an opcode of 0) is an Error naming the byte.
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>

#include "compression.hpp"
#include "mcap_format.hpp"
#include "storage_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl::rosbag2 {
namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kNotInChunk = ~std::uint64_t{0};

// A read-only view of the whole file.
class MappedFile {
 public:
  explicit MappedFile(const fs::path& file) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error("cannot open " + file.string() + ": " + std::strerror(errno));
    const off_t size = ::lseek(fd, 0, SEEK_END);
    if (size > 0) {
      void* p = ::mmap(nullptr, static_cast<std::size_t>(size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) {
        data_ = static_cast<const std::uint8_t*>(p);
        size_ = static_cast<std::size_t>(size);
      }
    }
    const int error = errno;
    ::close(fd);
    if (size > 0 && !data_) throw Error("cannot read " + file.string() + ": " + std::strerror(error));
  }
  ~MappedFile() {
    if (data_) ::munmap(const_cast<std::uint8_t*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const std::uint8_t* data() const { return data_; }
  std::size_t size() const { return size_; }

 private:
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
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
  explicit McapFile(const fs::path& file) : name_(file.string()), map_(file) {
    const std::size_t n = map_.size();
    constexpr std::size_t kHeaderAt = mcap::kMagicBytes;
    if (n < kHeaderAt + mcap::kRecordHeaderBytes || std::memcmp(map_.data(), mcap::kMagic, mcap::kMagicBytes) != 0 ||
        map_.data()[kHeaderAt] != mcap::kHeader ||
        io::load<std::uint64_t>(map_.data() + kHeaderAt + 1, true) > n - kHeaderAt - mcap::kRecordHeaderBytes) {
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
    const std::uint8_t* base = map_.data();
    std::uint64_t size = map_.size();
    if (at.a != kNotInChunk) {
      open_chunk(at.a);
      base = chunk_;
      size = chunk_size_;
    }
    if (at.b > size || size - at.b < mcap::kRecordHeaderBytes || base[at.b] != mcap::kMessage) {
      throw Error(name_ + ": the message at byte " + where(at) + " is no longer there (the file changed?)");
    }
    const std::uint64_t length = io::load<std::uint64_t>(base + at.b + 1, true);
    if (length > size - at.b - mcap::kRecordHeaderBytes) throw Error(name_ + ": the file changed while it was read");
    mcap::FieldReader fields(base + at.b + mcap::kRecordHeaderBytes, length, name_);
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

  // Channels and schemas from the summary section, where the footer points to one (with channels in it).
  bool read_summary() {
    const std::uint8_t* d = map_.data();
    const std::uint64_t n = map_.size();
    constexpr std::uint64_t kFooterRecord = mcap::kRecordHeaderBytes + mcap::kFooterContentBytes;
    if (n < mcap::kMagicBytes * 2 + kFooterRecord) return false;
    const std::uint64_t footer = n - mcap::kMagicBytes - kFooterRecord;
    if (std::memcmp(d + n - mcap::kMagicBytes, mcap::kMagic, mcap::kMagicBytes) != 0 || d[footer] != mcap::kFooter ||
        io::load<std::uint64_t>(d + footer + 1, true) != mcap::kFooterContentBytes) {
      return false;  // no footer: a recording cut off, read as a stream
    }
    mcap::FieldReader fields(d + footer + mcap::kRecordHeaderBytes, mcap::kFooterContentBytes, name_);
    const auto start = fields.value<std::uint64_t>("summary_start");
    const auto offsets = fields.value<std::uint64_t>("summary_offset_start");
    const auto crc = fields.value<std::uint32_t>("summary_crc");
    if (start == 0) return false;
    const std::uint64_t end = offsets != 0 ? offsets : footer;
    if (start < mcap::kMagicBytes || start > end || end > footer) {
      throw Error(name_ + ": corrupt MCAP: its footer places the summary at bytes " + std::to_string(start) + ".." +
                  std::to_string(end) + ", outside the file");
    }
    const std::uint32_t actual = crc32_of(d + start, footer + mcap::kRecordHeaderBytes + 16 - start);
    if (crc != 0 && actual != crc) {
      throw Error(name_ + ": corrupt MCAP: the summary's CRC is " + std::to_string(actual) + ", the footer says " +
                  std::to_string(crc));
    }
    // Schemas first: the specification groups summary records by opcode but does not order the groups.
    for (const std::uint8_t opcode : {mcap::kSchema, mcap::kChannel}) {
      walk_records(d, start, end, kNotInChunk, true, [&](const Record& r) {
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

  // Every record of the data section, those inside chunks included, in the file's order.
  template <typename F>
  void walk(F&& f) {
    const std::uint8_t* d = map_.data();
    const std::uint64_t n = map_.size();
    std::uint64_t pos = mcap::kMagicBytes;
    cut_note_.clear();
    while (pos < n) {
      if (n - pos < mcap::kRecordHeaderBytes || io::load<std::uint64_t>(d + pos + 1, true) > n - pos - 9) {
        cut_note_ = "; " + name_ + " ends inside a record at byte " + std::to_string(pos) +
                    " (a recording cut off?): read up to there";
        return;
      }
      const Record r{d[pos], d + pos + 9, io::load<std::uint64_t>(d + pos + 1, true), {kNotInChunk, pos}};
      if (r.opcode == 0) throw Error(name_ + ": corrupt MCAP: a record of opcode 0 at byte " + std::to_string(pos));
      if (r.opcode == mcap::kDataEnd || r.opcode == mcap::kFooter) return;  // the summary is not needed
      if (r.opcode == mcap::kChunk) {
        walk_chunk(pos, r, f);
      } else {
        f(r);
      }
      pos += mcap::kRecordHeaderBytes + r.size;
    }
    cut_note_ = "; " + name_ + " ends without its data end (a recording cut off?)";
  }

  template <typename F>
  void walk_chunk(std::uint64_t offset, const Record& chunk, F&& f) {
    open_chunk(offset, chunk);
    walk_records(chunk_, 0, chunk_size_, offset, false, f);
  }

  // The records in [begin, end) of `base`, which must fill it exactly.
  template <typename F>
  void walk_records(const std::uint8_t* base, std::uint64_t begin, std::uint64_t end, std::uint64_t chunk, bool summary,
                    F&& f) const {
    for (std::uint64_t pos = begin; pos < end;) {
      const std::uint64_t length =
          end - pos >= mcap::kRecordHeaderBytes ? io::load<std::uint64_t>(base + pos + 1, true) : ~std::uint64_t{0};
      if (length > end - pos - std::min<std::uint64_t>(end - pos, 9)) {
        throw Error(name_ + ": corrupt MCAP: the record at byte " + where({chunk, pos}) + " runs past the end of its " +
                    (summary ? "summary section" : "chunk"));
      }
      if (base[pos] == 0) throw Error(name_ + ": corrupt MCAP: a record of opcode 0 at byte " + where({chunk, pos}));
      f(Record{base[pos], base + pos + 9, length, {chunk, pos}});
      pos += mcap::kRecordHeaderBytes + length;
    }
  }

  // Makes chunk_ the records of the chunk record at `offset` (decompressed, its CRC checked).
  void open_chunk(std::uint64_t offset) {
    if (offset == chunk_offset_) return;
    const std::uint8_t* d = map_.data();
    if (offset > map_.size() || map_.size() - offset < mcap::kRecordHeaderBytes || d[offset] != mcap::kChunk) {
      throw Error(name_ + ": the chunk at byte " + std::to_string(offset) + " is no longer there (the file changed?)");
    }
    const std::uint64_t length = io::load<std::uint64_t>(d + offset + 1, true);
    if (length > map_.size() - offset - mcap::kRecordHeaderBytes) throw Error(name_ + ": the file changed while read");
    open_chunk(offset, Record{mcap::kChunk, d + offset + 9, length, {kNotInChunk, offset}});
  }

  void open_chunk(std::uint64_t offset, const Record& chunk) {
    if (offset == chunk_offset_) return;
    chunk_offset_ = kNotInChunk;
    const std::string what = name_ + ": the chunk at byte " + std::to_string(offset);
    mcap::FieldReader fields(chunk.content, chunk.size, what);
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
    if (crc != 0 && crc32_of(chunk_, chunk_size_) != crc) {
      throw Error(what + ": CRC mismatch: its records' CRC-32 is " + std::to_string(crc32_of(chunk_, chunk_size_)) +
                  ", the chunk says " + std::to_string(crc));
    }
    chunk_offset_ = offset;
  }

  std::string name_;
  MappedFile map_;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<StoredTopic> topics_;
  std::map<std::string, std::size_t> topic_index_;
  std::string cut_note_;
  // The chunk last opened: its records (in the file, or in buffer_ decompressed).
  std::uint64_t chunk_offset_ = kNotInChunk;
  const std::uint8_t* chunk_ = nullptr;
  std::uint64_t chunk_size_ = 0;
  Decompressed buffer_;
};

}  // namespace

std::unique_ptr<StorageFile> open_mcap_file(const fs::path& file) { return std::make_unique<McapFile>(file); }

}  // namespace tsdf_mcl::rosbag2
