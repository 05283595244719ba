#pragma once
// The compressions rosbag2 recordings use: zstd and LZ4 frames in MCAP chunks (Debian's libzstd and liblz4), zstd
// frames for rosbag2's per-message compression; and CRC-32 (zlib's), which MCAP checks chunks and sections with.
//
// Decompression streams into a buffer that grows with what comes out, up to the size the container declares: a chunk
// that declares a gigabyte and holds a kilobyte costs a kilobyte, and one that holds more or less than it declares is
// an Error.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace tsdf_mcl::rosbag2 {

// Bytes decompressed into a buffer kept from one use to the next.
class Decompressed {
 public:
  const std::uint8_t* data() const { return buffer_.get(); }
  std::size_t size() const { return size_; }
  // Room for at least `n` bytes, the first size() kept; returns where the free space starts.
  std::uint8_t* reserve(std::size_t n);
  void clear() { size_ = 0; }
  void grew(std::size_t n) { size_ += n; }
  std::size_t capacity() const { return capacity_; }

 private:
  std::unique_ptr<std::uint8_t[]> buffer_;  // not value-initialized: its pages cost nothing until written
  std::size_t capacity_ = 0, size_ = 0;
};

// Decompresses `size` bytes of `compression` ("zstd" or "lz4") into `out`, which must come to exactly `declared`
// bytes; throws Error("WHAT: ...") for another compression, corrupt data, or another size.
void decompress(const std::string& compression, const std::uint8_t* data, std::size_t size, std::uint64_t declared,
                Decompressed& out, const std::string& what);
// The other way, for the MCAP writer.
std::string compress(const std::string& compression, const std::string& data);

// A zstd frame's first bytes: rosbag2 compresses each message so with --compression-mode message (plain CDR starts
// with a zero byte).
bool is_zstd_frame(const std::uint8_t* data, std::size_t size);
// Such a message decompressed: its frame must state its size, at most `max_size`.
void decompress_zstd_frame(const std::uint8_t* data, std::size_t size, std::size_t max_size, Decompressed& out,
                           const std::string& what);

std::uint32_t crc32_of(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace tsdf_mcl::rosbag2
