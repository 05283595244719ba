#pragma once
// Little-endian encoding of file formats (map files, binary PLY), independent of the host's byte order.
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>

namespace tsdf_mcl::io {

inline constexpr bool kHostIsLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

template <typename T>
T byte_swapped(T value) {
  static_assert(std::is_trivially_copyable_v<T> &&
                (sizeof(T) == 1 || sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8));
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

// Reads a value stored with the given byte order from unaligned memory.
template <typename T>
T load(const unsigned char* bytes, bool little_endian) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return little_endian == kHostIsLittleEndian ? value : byte_swapped(value);
}

template <typename T>
void append_le(std::string& out, T value) {
  if (!kHostIsLittleEndian) value = byte_swapped(value);
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace tsdf_mcl::io
