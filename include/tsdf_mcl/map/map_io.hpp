#pragma once
// The project's own map file (.tsdf): versioned little-endian header, sizes, CRC-32 of the payload (map.md).
// The importer for the reference implementation's HDF5 maps is mapping/h5_import.hpp.
#include <filesystem>

#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

void save_map(const TsdfMap& map, const std::filesystem::path& file);
// Throws Error with a one-line reason for a missing, truncated, corrupt or wrong-version file.
TsdfMap load_map(const std::filesystem::path& file);

}  // namespace tsdf_mcl
