#pragma once
// The importer for the HDF5 maps of the reference implementation (uos/tsdf_localization).
#include <cstdint>
#include <filesystem>

#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// Reference HDF5 layout: group /map, datasets "cx_cy_cz" of 64^3 uint32 (z fastest), each word
// int16 TSDF in mm (low half) | int16 weight (high half, 0 = unobserved), voxel (cx*64+i, ...) at index*0.064 m.
// The map and the import's buffers must fit in max_memory_bytes (else an Error names the budget).
TsdfMap import_reference_h5(const std::filesystem::path& file, float truncation = 0.6f,
                            std::uint64_t max_memory_bytes = std::uint64_t{limits::kDefaultBuildMemoryMiB} << 20);
// The same in a child process (io/isolated_call.hpp), as callers that read files from elsewhere should: libhdf5
// itself can crash on a crafted file (tests/data/libhdf5_crash_local_heap.h5) before any of our checks see data,
// which is one Error here. The child hands the map over through a scratch file in `scratch_dir` (default: the
// system's temporary folder), removed afterwards.
TsdfMap import_reference_h5_isolated(const std::filesystem::path& file, float truncation = 0.6f,
                                     std::uint64_t max_memory_bytes = std::uint64_t{limits::kDefaultBuildMemoryMiB}
                                                                      << 20,
                                     const std::filesystem::path& scratch_dir = {});

}  // namespace tsdf_mcl
