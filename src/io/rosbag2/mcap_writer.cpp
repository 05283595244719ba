#include "mcap_writer.hpp"

#include <algorithm>

#include "compression.hpp"
#include "mcap_format.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::rosbag2 {

using mcap::FieldWriter;
using mcap::record;

McapWriter::McapWriter(const std::filesystem::path& file, Options options)
    : file_(file), options_(std::move(options)), out_(file, std::ios::binary | std::ios::trunc) {
  if (!out_) throw Error("cannot create " + file.string());
  if (!options_.compression.empty()) compress(options_.compression, "");  // an unknown name fails here, not later
  put(std::string(mcap::kMagic, mcap::kMagicBytes));
  put(record(mcap::kHeader, FieldWriter().string("ros2").string("tsdf-mcl").bytes()));
}

std::uint16_t McapWriter::add_channel(const std::string& topic, const std::string& type, const std::string& definition,
                                      const std::string& offered_qos_profiles) {
  auto schema = schema_ids_.find(type);
  if (schema == schema_ids_.end()) {
    schema = schema_ids_.emplace(type, static_cast<std::uint16_t>(schema_ids_.size() + 1)).first;
    const std::string r = record(
        mcap::kSchema,
        FieldWriter().value<std::uint16_t>(schema->second).string(type).string("ros2msg").string(definition).bytes());
    schemas_ += r;
    add_to_chunk(r, 0, 0);
  }
  const std::uint16_t id = ++channel_count_;
  // Map<string, string>: a byte length, then the entries.
  const std::string metadata = FieldWriter().string("offered_qos_profiles").string(offered_qos_profiles).bytes();
  const std::string r = record(mcap::kChannel, FieldWriter()
                                                   .value<std::uint16_t>(id)
                                                   .value<std::uint16_t>(schema->second)
                                                   .string(topic)
                                                   .string("cdr")
                                                   .string(metadata)
                                                   .bytes());
  channels_ += r;
  add_to_chunk(r, 0, 0);
  return id;
}

void McapWriter::write(std::uint16_t channel, std::uint64_t log_time_ns, const std::vector<std::uint8_t>& data) {
  FieldWriter content;
  content.value<std::uint16_t>(channel)
      .value<std::uint32_t>(static_cast<std::uint32_t>(channel_messages_[channel]))
      .value<std::uint64_t>(log_time_ns)
      .value<std::uint64_t>(log_time_ns)
      .raw(std::string(data.begin(), data.end()));
  if (messages_ == 0 || log_time_ns < start_) start_ = log_time_ns;
  end_ = std::max(end_, log_time_ns);
  ++messages_;
  ++channel_messages_[channel];
  add_to_chunk(record(mcap::kMessage, content.bytes()), channel, log_time_ns);
  if (chunk_.size() >= options_.chunk_bytes) flush_chunk();
}

void McapWriter::add_to_chunk(const std::string& r, std::uint16_t channel, std::uint64_t log_time) {
  if (channel != 0) {
    if (chunk_index_.empty() || log_time < chunk_start_) chunk_start_ = log_time;
    chunk_end_ = std::max(chunk_end_, log_time);
    chunk_index_[channel].emplace_back(log_time, chunk_.size());
  }
  chunk_ += r;
}

void McapWriter::flush_chunk() {
  if (chunk_.empty()) return;
  ChunkIndex index;
  index.start = chunk_index_.empty() ? 0 : chunk_start_;
  index.end = chunk_index_.empty() ? 0 : chunk_end_;
  index.offset = offset_;
  index.uncompressed = chunk_.size();
  const std::string records = options_.compression.empty() ? chunk_ : compress(options_.compression, chunk_);
  index.compressed = records.size();
  const std::uint32_t crc = crc32_of(reinterpret_cast<const std::uint8_t*>(chunk_.data()), chunk_.size());
  FieldWriter content;
  content.value<std::uint64_t>(index.start)
      .value<std::uint64_t>(index.end)
      .value<std::uint64_t>(chunk_.size())
      .value<std::uint32_t>(crc)
      .string(options_.compression)
      .value<std::uint64_t>(records.size())
      .raw(records);
  put(record(mcap::kChunk, content.bytes()));
  index.length = offset_ - index.offset;
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    FieldWriter array;
    for (const auto& [time, at] : entries) array.value<std::uint64_t>(time).value<std::uint64_t>(at);
    index.index_offsets[channel] = offset_;
    put(record(mcap::kMessageIndex, FieldWriter().value<std::uint16_t>(channel).string(array.bytes()).bytes()));
  }
  index.index_length = offset_ - indexes_start;
  chunks_.push_back(std::move(index));
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::put(const std::string& bytes) {
  out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  crc_ = crc32_of(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), crc_);
  offset_ += bytes.size();
}

void McapWriter::write_summary() {
  const std::uint64_t summary_start = offset_;
  crc_ = 0;  // from here on: the summary's CRC
  std::vector<std::pair<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>>> groups;
  const auto group = [&](std::uint8_t opcode, const std::string& records) {
    if (records.empty()) return;
    groups.push_back({opcode, {offset_, records.size()}});
    put(records);
  };
  group(mcap::kSchema, schemas_);
  group(mcap::kChannel, channels_);
  FieldWriter counts;
  for (const auto& [channel, n] : channel_messages_) counts.value<std::uint16_t>(channel).value<std::uint64_t>(n);
  group(mcap::kStatistics,
        record(mcap::kStatistics, FieldWriter()
                                      .value<std::uint64_t>(messages_)
                                      .value<std::uint16_t>(static_cast<std::uint16_t>(schema_ids_.size()))
                                      .value<std::uint32_t>(channel_count_)
                                      .value<std::uint32_t>(0)
                                      .value<std::uint32_t>(0)
                                      .value<std::uint32_t>(static_cast<std::uint32_t>(chunks_.size()))
                                      .value<std::uint64_t>(messages_ ? start_ : 0)
                                      .value<std::uint64_t>(messages_ ? end_ : 0)
                                      .string(counts.bytes())
                                      .bytes()));
  std::string chunk_indexes;
  for (const ChunkIndex& c : chunks_) {
    FieldWriter offsets;
    for (const auto& [channel, at] : c.index_offsets) offsets.value<std::uint16_t>(channel).value<std::uint64_t>(at);
    chunk_indexes += record(mcap::kChunkIndex, FieldWriter()
                                                   .value<std::uint64_t>(c.start)
                                                   .value<std::uint64_t>(c.end)
                                                   .value<std::uint64_t>(c.offset)
                                                   .value<std::uint64_t>(c.length)
                                                   .string(offsets.bytes())
                                                   .value<std::uint64_t>(c.index_length)
                                                   .string(options_.compression)
                                                   .value<std::uint64_t>(c.compressed)
                                                   .value<std::uint64_t>(c.uncompressed)
                                                   .bytes());
  }
  group(mcap::kChunkIndex, chunk_indexes);
  const std::uint64_t offsets_start = offset_;
  for (const auto& [opcode, at] : groups) {
    put(record(mcap::kSummaryOffset, FieldWriter()
                                         .value<std::uint8_t>(opcode)
                                         .value<std::uint64_t>(at.first)
                                         .value<std::uint64_t>(at.second)
                                         .bytes()));
  }
  // The footer's CRC covers the summary up to and including its own summary_offset_start.
  const std::string footer = record(mcap::kFooter, FieldWriter()
                                                       .value<std::uint64_t>(summary_start)
                                                       .value<std::uint64_t>(offsets_start)
                                                       .value<std::uint32_t>(0)
                                                       .bytes());
  const std::uint32_t crc = crc32_of(reinterpret_cast<const std::uint8_t*>(footer.data()), footer.size() - 4, crc_);
  std::string sealed = footer;
  sealed.replace(sealed.size() - 4, 4, FieldWriter().value<std::uint32_t>(crc).bytes());
  put(sealed);
}

void McapWriter::close() {
  flush_chunk();
  put(record(mcap::kDataEnd, FieldWriter().value<std::uint32_t>(crc_).bytes()));
  if (options_.summary) {
    write_summary();
  } else {
    put(record(mcap::kFooter,
               FieldWriter().value<std::uint64_t>(0).value<std::uint64_t>(0).value<std::uint32_t>(0).bytes()));
  }
  put(std::string(mcap::kMagic, mcap::kMagicBytes));
  out_.close();
  if (!out_) throw Error("cannot write " + file_.string() + " (disk full?)");
}

}  // namespace tsdf_mcl::rosbag2
