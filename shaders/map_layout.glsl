// TSDF map layout shared by the shaders; mirrors tsdf_mcl/map/tsdf_map.hpp and tsdf_mcl/map/map_lookup.hpp (block size 8, sentinels,
// int16 quantized distances, two per uint with the even voxel in the low half).
#ifndef MAP_LAYOUT_GLSL
#define MAP_LAYOUT_GLSL

const uint BLOCK_WORDS = 256u;
const uint UNKNOWN_BLOCK = 0xFFFFFFFFu;
const uint FREE_BLOCK = 0xFFFFFFFEu;
const int UNKNOWN_VALUE = -32768;
const int QUANT_MAX = 32767;

#endif
