// Import of the HDF5 maps written for the reference implementation (uos/tsdf_localization): group /map, one
// dataset of 64^3 uint32 per chunk, named "cx_cy_cz"; word = int16 TSDF in mm (low half) | int16 weight (high).
#include <hdf5.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <charconv>
#include <cmath>
#include <limits>
#include <set>
#include <tuple>
#include <string>
#include <vector>

#include "build_budget.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/io/isolated_call.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/mapping/h5_import.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

constexpr int kChunkSize = 64;
constexpr int kChunkVoxels = kChunkSize * kChunkSize * kChunkSize;
constexpr int kBlocksPerChunk = kChunkSize / TsdfMap::kBlockSize;
constexpr float kReferenceVoxelSize = 0.064f;

// Owns one HDF5 identifier; the close function depends on the kind of object.
class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Handle() {
    if (id_ >= 0) close_(id_);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

bool parse_int(std::string_view s, int& value) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return !s.empty() && ec == std::errc() && end == s.data() + s.size();
}

bool parse_chunk_name(const std::string& name, Eigen::Vector3i& chunk) {
  const std::size_t a = name.find('_');
  const std::size_t b = a == std::string::npos ? a : name.find('_', a + 1);
  if (b == std::string::npos) return false;
  const std::string_view s(name);
  return parse_int(s.substr(0, a), chunk.x()) && parse_int(s.substr(a + 1, b - a - 1), chunk.y()) &&
         parse_int(s.substr(b + 1), chunk.z());
}

struct Chunk {
  std::string name;
  Eigen::Vector3i index;
};

std::vector<std::uint32_t> read_chunk(hid_t group, const Chunk& chunk, const std::string& where) {
  const std::string what = where + ": dataset /map/" + chunk.name;
  const H5Handle set(H5Dopen2(group, chunk.name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) throw Error(what + " is not a dataset");
  const H5Handle type(H5Dget_type(set.get()), H5Tclose);
  if (!type.valid() || H5Tget_class(type.get()) != H5T_INTEGER || H5Tget_size(type.get()) != 4) {
    throw Error(what + " does not hold 32-bit integers");
  }
  const H5Handle space(H5Dget_space(set.get()), H5Sclose);
  const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  hsize_t dims[H5S_MAX_RANK] = {};
  if (rank < 1 || H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0 ||
      H5Sget_simple_extent_npoints(space.get()) != kChunkVoxels ||
      !(rank == 1 || (rank == 3 && dims[0] == kChunkSize && dims[1] == kChunkSize && dims[2] == kChunkSize))) {
    throw Error(what + " does not have the shape of a 64^3 chunk");
  }
  // libhdf5 (1.10) trusts the dataspace over the sizes stored for the data and reads past its own buffer when they
  // disagree (found by fuzzing): a compact dataset must store the whole chunk, and an unfiltered chunked one whole
  // HDF5 chunks.
  const H5Handle plist(H5Dget_create_plist(set.get()), H5Pclose);
  const H5D_layout_t layout = plist.valid() ? H5Pget_layout(plist.get()) : H5D_LAYOUT_ERROR;
  const hsize_t stored = H5Dget_storage_size(set.get());
  bool sizes_agree =
      layout == H5D_CONTIGUOUS || (layout == H5D_COMPACT && stored == static_cast<hsize_t>(kChunkVoxels) * 4);
  if (layout == H5D_CHUNKED) {
    // No HDF5 chunk of a 64^3 dataset needs to be larger than the dataset; libhdf5 allocates and fills a whole one
    // before reading (a fuzzed file declared 7995456 x 1 x 64 words: 2 GB, and minutes of memset).
    hsize_t chunk_dims[H5S_MAX_RANK] = {};
    const int chunk_rank = H5Pget_chunk(plist.get(), H5S_MAX_RANK, chunk_dims);
    constexpr hsize_t kDatasetBytes = static_cast<hsize_t>(kChunkVoxels) * 4;
    hsize_t chunk_bytes = 4;
    bool bounded = chunk_rank > 0;
    for (int a = 0; a < chunk_rank && bounded; ++a) {
      bounded = chunk_dims[a] > 0 && chunk_dims[a] <= static_cast<hsize_t>(kChunkVoxels);
      chunk_bytes *= bounded ? chunk_dims[a] : 1;  // at most 2^20 * 2^18: no overflow
      bounded = bounded && chunk_bytes <= kDatasetBytes;
    }
    sizes_agree = bounded && (H5Pget_nfilters(plist.get()) != 0 || stored % chunk_bytes == 0);
  }
  if (!sizes_agree) throw Error(what + ": the stored data does not match its 64^3 shape (corrupt)");
  std::vector<std::uint32_t> words(kChunkVoxels);
  if (H5Dread(set.get(), H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, words.data()) < 0) {
    throw Error("cannot read " + what);
  }
  return words;
}

// The chunks /map names, each checked, and the box of chunk indices they span.
struct ChunkList {
  std::vector<Chunk> chunks;
  Eigen::Vector3i lo = Eigen::Vector3i::Constant(INT32_MAX), hi = Eigen::Vector3i::Constant(INT32_MIN);
};

ChunkList list_chunks(hid_t group_id, hsize_t links, const std::string& where) {
  ChunkList list;
  std::set<std::tuple<int, int, int>> seen;
  for (hsize_t i = 0; i < links; ++i) {
    const ssize_t length = H5Lget_name_by_idx(group_id, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (length < 0) throw Error("cannot list /map in " + where);
    std::string name(static_cast<std::size_t>(length) + 1, '\0');
    H5Lget_name_by_idx(group_id, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT);
    name.resize(static_cast<std::size_t>(length));
    Chunk c{name, {}};
    if (!parse_chunk_name(name, c.index)) {
      throw Error(where + ": dataset /map/" + name + " is not named like a chunk (cx_cy_cz)");
    }
    // Voxel indices chunk*64 + 63 must stay within int with room for the block arithmetic.
    if ((c.index.array().abs() > (1 << 20)).any())
      throw Error(where + ": chunk /map/" + name + " is implausibly far out");
    if (!seen.emplace(c.index.x(), c.index.y(), c.index.z()).second) {
      throw Error(where + ": two datasets name chunk " + name);
    }
    list.lo = list.lo.cwiseMin(c.index);
    list.hi = list.hi.cwiseMax(c.index);
    list.chunks.push_back(std::move(c));
  }
  return list;
}

// One chunk's voxels into the map's blocks; a block with no observed voxel stays unknown.
void copy_chunk(TsdfMap& map, const Chunk& c, const std::vector<std::uint32_t>& words) {
  std::array<std::int16_t, TsdfMap::kVoxelsPerBlock> block{};
  for (int bz = 0; bz < kBlocksPerChunk; ++bz)
    for (int by = 0; by < kBlocksPerChunk; ++by)
      for (int bx = 0; bx < kBlocksPerChunk; ++bx) {
        bool any_known = false;
        for (int lz = 0; lz < TsdfMap::kBlockSize; ++lz)
          for (int ly = 0; ly < TsdfMap::kBlockSize; ++ly)
            for (int lx = 0; lx < TsdfMap::kBlockSize; ++lx) {
              const int i = bx * TsdfMap::kBlockSize + lx;
              const int j = by * TsdfMap::kBlockSize + ly;
              const int k = bz * TsdfMap::kBlockSize + lz;
              const std::uint32_t word = words[static_cast<std::size_t>((i * kChunkSize + j) * kChunkSize + k)];
              const auto value_mm = static_cast<std::int16_t>(word & 0xFFFFu);
              const auto weight = static_cast<std::int16_t>(word >> 16);
              auto& out = block[static_cast<std::size_t>(lx + TsdfMap::kBlockSize * (ly + TsdfMap::kBlockSize * lz))];
              // Integration only ever adds positive weights, so anything else is an unobserved voxel.
              if (weight <= 0) {
                out = TsdfMap::kUnknownValue;
              } else {
                out = map.quantize(static_cast<float>(value_mm) * 0.001f);
                any_known = true;
              }
            }
        if (any_known) map.set_block(c.index * kBlocksPerChunk + Eigen::Vector3i(bx, by, bz), block);
      }
}

}  // namespace

TsdfMap import_reference_h5(const fs::path& file, float truncation, std::uint64_t max_memory_bytes) {
  if (!(truncation >= kReferenceVoxelSize) || !std::isfinite(truncation)) {
    throw Error("truncation " + std::to_string(truncation) +
                " m must be at least the reference maps' voxel size (0.064 m)");
  }
  const std::string where = "HDF5 map " + file.string();
  input_file_size(file, "HDF5 map", std::numeric_limits<std::uint64_t>::max());
  // The library would print its own error stack to stderr; every failure is reported through Error instead.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (H5Fis_hdf5(file.c_str()) <= 0) throw Error(where + ": not an HDF5 file");
  const H5Handle h5(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h5.valid()) throw Error("cannot open " + where);
  if (H5Lexists(h5.get(), "map", H5P_DEFAULT) <= 0) throw Error(where + ": no /map group (not a reference TSDF map)");
  const H5Handle group(H5Gopen2(h5.get(), "map", H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw Error(where + ": /map is not a group");
  H5G_info_t info{};
  if (H5Gget_info(group.get(), &info) < 0) throw Error("cannot list /map in " + where);

  const ChunkList list = list_chunks(group.get(), info.nlinks, where);
  const std::vector<Chunk>& chunks = list.chunks;
  if (chunks.empty()) throw Error(where + ": /map holds no chunks");

  const Eigen::Vector3i min_block = list.lo * kBlocksPerChunk;
  const Eigen::Vector3i dims = (list.hi - list.lo).array() * kBlocksPerChunk + kBlocksPerChunk;
  TsdfMap::validate_geometry(kReferenceVoxelSize, truncation, min_block, dims);
  BuildBudget budget(max_memory_bytes);
  budget.charge(dims.cast<std::uint64_t>().prod() * sizeof(std::uint32_t), "the chunks' bounding box in blocks");
  // Every block of every chunk may be known: its pool block, and its copy while the pool is compacted.
  constexpr std::uint64_t kChunkPoolBytes = std::uint64_t{kBlocksPerChunk * kBlocksPerChunk * kBlocksPerChunk} *
                                            TsdfMap::kWordsPerBlock * sizeof(std::uint32_t);
  budget.charge(chunks.size() * 2 * kChunkPoolBytes, "the chunks' blocks");
  TsdfMap map(kReferenceVoxelSize, truncation, min_block, dims);
  for (const Chunk& c : chunks) copy_chunk(map, c, read_chunk(group.get(), c, where));
  map.compact();
  return map;
}

TsdfMap import_reference_h5_isolated(const fs::path& file, float truncation, std::uint64_t max_memory_bytes,
                                     const fs::path& scratch_dir) {
  static std::atomic<unsigned> calls{0};
  const fs::path scratch =
      (scratch_dir.empty() ? fs::temp_directory_path() : scratch_dir) /
      ("tsdf_mcl_h5_import." + std::to_string(::getpid()) + "." + std::to_string(calls++) + ".tsdf");
  // Removed however the import ends (the child may have written it before a later failure).
  struct Remove {
    const fs::path& file;
    ~Remove() {
      std::error_code ec;
      fs::remove(file, ec);
    }
  } remove{scratch};
  call_isolated(
      [&] {
        save_map(import_reference_h5(file, truncation, max_memory_bytes), scratch);
        return std::string();
      },
      [&](const std::string& how) {
        return file.string() + ": the HDF5 library crashed reading it (" + how + "): the file is corrupt";
      });
  return load_map(scratch);
}

}  // namespace tsdf_mcl
