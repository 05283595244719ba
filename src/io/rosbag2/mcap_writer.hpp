#pragma once
// Writing an MCAP file (mcap_format.hpp) as rosbag2's MCAP storage does: profile "ros2", one ros2msg Schema per type
// and one cdr Channel per topic (its offered_qos_profiles in the channel's metadata), messages in chunks of about
// 768 KiB (uncompressed, zstd or lz4), each chunk followed by its Message Index records; then the Data End and,
// unless left out, the summary (schemas, channels, statistics, chunk indexes), its Summary Offsets and the Footer,
// every CRC filled in.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace tsdf_mcl::rosbag2 {

class McapWriter {
 public:
  struct Options {
    std::string compression;  // "", "zstd", "lz4"
    bool summary = true;
    std::uint64_t chunk_bytes = 768 * 1024;
  };
  // Throws Error where the file cannot be created.
  McapWriter(const std::filesystem::path& file, Options options);

  // A channel for `topic` of `type` (its schema written once per type); returns its id.
  std::uint16_t add_channel(const std::string& topic, const std::string& type, const std::string& definition,
                            const std::string& offered_qos_profiles);
  void write(std::uint16_t channel, std::uint64_t log_time_ns, const std::vector<std::uint8_t>& data);
  // Ends the file (the last chunk, Data End, summary, Footer, magic) and closes it; throws Error where writing failed.
  void close();

 private:
  struct ChunkIndex {
    std::uint64_t start = 0, end = 0, offset = 0, length = 0, index_length = 0, uncompressed = 0, compressed = 0;
    std::map<std::uint16_t, std::uint64_t> index_offsets;
  };
  void put(const std::string& bytes);  // to the file, counted in the data section's CRC
  void add_to_chunk(const std::string& record, std::uint16_t channel, std::uint64_t log_time);
  void flush_chunk();
  void write_summary();

  std::filesystem::path file_;
  Options options_;
  std::ofstream out_;
  std::uint64_t offset_ = 0;
  std::uint32_t crc_ = 0;
  std::map<std::string, std::uint16_t> schema_ids_;  // by type
  std::string schemas_, channels_;                   // their records, again for the summary
  std::map<std::uint16_t, std::uint64_t> channel_messages_;
  std::uint16_t channel_count_ = 0;
  std::uint64_t messages_ = 0, start_ = 0, end_ = 0;
  // The open chunk: its records, time range, and per channel the (log time, offset) of each message.
  std::string chunk_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::vector<ChunkIndex> chunks_;
};

}  // namespace tsdf_mcl::rosbag2
