// The .tsdf map file, all little-endian:
//   0  char[8]  magic "TSDFMCL\0"
//   8  uint32   format version (kFormatVersion)
//  12  float32  voxel size (m)
//  16  float32  truncation (m)
//  20  uint32   block size (voxels per block edge)
//  24  int32[3] min_block
//  36  int32[3] dims_blocks
//  48  uint64   coarse index entries
//  56  uint64   block pool words
//  64  uint32[] coarse index, then uint32[] block pool
// end  uint32   CRC-32 (IEEE) of every byte before it
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <fstream>
#include <string>

#include <zlib.h>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

constexpr char kMagic[8] = {'T', 'S', 'D', 'F', 'M', 'C', 'L', '\0'};
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::size_t kHeaderBytes = 64;

// CRC-32 (zlib's: the checksum of gzip and PNG, table-driven and fast on maps of hundreds of MB).
class Crc32 {
 public:
  void update(const void* data, std::size_t size) { crc_ = crc32_z(crc_, static_cast<const Bytef*>(data), size); }
  std::uint32_t value() const { return static_cast<std::uint32_t>(crc_); }

 private:
  uLong crc_ = crc32_z(0L, Z_NULL, 0);
};

std::string header_bytes(const TsdfMap& map) {
  std::string h(kMagic, sizeof(kMagic));
  io::append_le(h, kFormatVersion);
  io::append_le(h, map.voxel_size());
  io::append_le(h, map.truncation());
  io::append_le(h, static_cast<std::uint32_t>(TsdfMap::kBlockSize));
  for (int a = 0; a < 3; ++a) io::append_le(h, static_cast<std::int32_t>(map.min_block()[a]));
  for (int a = 0; a < 3; ++a) io::append_le(h, static_cast<std::int32_t>(map.dims_blocks()[a]));
  io::append_le(h, static_cast<std::uint64_t>(map.coarse_index().size()));
  io::append_le(h, static_cast<std::uint64_t>(map.block_pool().size()));
  return h;
}

// Words in file byte order: the buffers themselves on little-endian hosts, a swapped copy elsewhere.
class LeWords {
 public:
  explicit LeWords(const std::vector<std::uint32_t>& words) : words_(&words) {
    if (!io::kHostIsLittleEndian) {
      swapped_.reserve(words.size());
      for (std::uint32_t w : words) swapped_.push_back(io::byte_swapped(w));
      words_ = &swapped_;
    }
  }
  const char* data() const { return reinterpret_cast<const char*>(words_->data()); }
  std::size_t bytes() const { return words_->size() * sizeof(std::uint32_t); }

 private:
  const std::vector<std::uint32_t>* words_;
  std::vector<std::uint32_t> swapped_;
};

void read_words(std::ifstream& in, std::vector<std::uint32_t>& words, Crc32& crc) {
  in.read(reinterpret_cast<char*>(words.data()), static_cast<std::streamsize>(words.size() * sizeof(std::uint32_t)));
  crc.update(words.data(), words.size() * sizeof(std::uint32_t));
  if (!io::kHostIsLittleEndian) {
    for (std::uint32_t& w : words) w = io::byte_swapped(w);
  }
}

}  // namespace

void save_map(const TsdfMap& map, const fs::path& file) {
  if (map.empty()) throw Error("cannot save an empty map to " + file.string());
  const std::string header = header_bytes(map);
  const LeWords coarse(map.coarse_index());
  const LeWords pool(map.block_pool());
  Crc32 crc;
  crc.update(header.data(), header.size());
  crc.update(coarse.data(), coarse.bytes());
  crc.update(pool.data(), pool.bytes());
  std::string trailer;
  io::append_le(trailer, crc.value());

  // Written beside the target and renamed over it, so a failed or interrupted save never leaves a half-written
  // map where a good one was.
  write_file_atomically(
      file,
      [&](const fs::path& temporary) {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        out.write(header.data(), static_cast<std::streamsize>(header.size()));
        out.write(coarse.data(), static_cast<std::streamsize>(coarse.bytes()));
        out.write(pool.data(), static_cast<std::streamsize>(pool.bytes()));
        out.write(trailer.data(), static_cast<std::streamsize>(trailer.size()));
        out.close();
        if (!out) throw Error("cannot write map " + file.string() + " (disk full?)");
      },
      "map");
}

TsdfMap load_map(const fs::path& file) {
  const std::string name = "map " + file.string();
  const std::uint64_t size = input_file_size(file, "map", std::numeric_limits<std::uint64_t>::max());
  if (size == 0) throw Error(name + ": empty file");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("cannot open " + name);

  unsigned char header[kHeaderBytes] = {};
  in.read(reinterpret_cast<char*>(header), static_cast<std::streamsize>(std::min<std::uint64_t>(size, kHeaderBytes)));
  const std::size_t magic_bytes = static_cast<std::size_t>(std::min<std::uint64_t>(size, sizeof(kMagic)));
  if (std::memcmp(header, kMagic, magic_bytes) != 0) throw Error(name + ": not a tsdf-mcl map (bad magic)");
  if (size < kHeaderBytes) {
    throw Error(name + ": truncated: expected at least " + std::to_string(kHeaderBytes) + " bytes (header), got " +
                std::to_string(size));
  }
  const auto version = io::load<std::uint32_t>(header + 8, true);
  if (version != kFormatVersion) {
    throw Error(name + ": unsupported format version " + std::to_string(version) + " (this build reads version " +
                std::to_string(kFormatVersion) + ")");
  }
  const auto voxel_size = io::load<float>(header + 12, true);
  const auto truncation = io::load<float>(header + 16, true);
  const auto block_size = io::load<std::uint32_t>(header + 20, true);
  Eigen::Vector3i min_block, dims;
  for (int a = 0; a < 3; ++a) {
    min_block[a] = io::load<std::int32_t>(header + 24 + 4 * a, true);
    dims[a] = io::load<std::int32_t>(header + 36 + 4 * a, true);
  }
  const auto coarse_count = io::load<std::uint64_t>(header + 48, true);
  const auto pool_words = io::load<std::uint64_t>(header + 56, true);
  if (block_size != TsdfMap::kBlockSize) {
    throw Error(name + ": block size " + std::to_string(block_size) + " not supported (this build uses " +
                std::to_string(TsdfMap::kBlockSize) + ")");
  }
  // Counts beyond 2^40 words cannot come from a real map; refusing them keeps the size arithmetic exact.
  constexpr std::uint64_t kMaxWords = std::uint64_t{1} << 40;
  if (coarse_count > kMaxWords || pool_words > kMaxWords) {
    throw Error(name + ": header claims " + std::to_string(coarse_count) + " index and " + std::to_string(pool_words) +
                " pool words (corrupt header)");
  }
  const std::uint64_t expected = kHeaderBytes + 4 * (coarse_count + pool_words) + 4;
  if (size < expected) {
    throw Error(name + ": truncated: expected " + std::to_string(expected) + " bytes, got " + std::to_string(size));
  }
  if (size > expected) {
    throw Error(name + ": " + std::to_string(size) + " bytes, but its header accounts for " + std::to_string(expected) +
                " (trailing data or corrupt header)");
  }

  // The geometry is checked before the payload is read: a header out of range says so, whatever the file's size.
  try {
    TsdfMap::validate_geometry(voxel_size, truncation, min_block, dims);
  } catch (const Error& e) {
    throw Error(name + ": header out of range: " + e.what());
  }
  if (coarse_count != dims.cast<std::uint64_t>().prod()) {
    throw Error(name + ": header names " + std::to_string(coarse_count) + " coarse index entries for a box of " +
                std::to_string(dims.cast<std::uint64_t>().prod()) + " blocks (corrupt header)");
  }

  Crc32 crc;
  crc.update(header, kHeaderBytes);
  std::vector<std::uint32_t> coarse(coarse_count);
  std::vector<std::uint32_t> pool(pool_words);
  read_words(in, coarse, crc);
  read_words(in, pool, crc);
  unsigned char trailer[4] = {};
  in.read(reinterpret_cast<char*>(trailer), 4);
  if (!in) throw Error("cannot read " + name);
  if (io::load<std::uint32_t>(trailer, true) != crc.value()) throw Error(name + ": checksum mismatch (file corrupt)");

  try {
    return TsdfMap::from_buffers(voxel_size, truncation, min_block, dims, std::move(coarse), std::move(pool));
  } catch (const Error& e) {
    throw Error(name + ": inconsistent contents: " + e.what());
  }
}

}  // namespace tsdf_mcl
