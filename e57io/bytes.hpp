#pragma once
// Little-endian loads and stores (E57 binary data is little-endian; we assume a little-endian
// host, as all our targets are, and check it at compile time).

#include <bit>
#include <cstdint>
#include <cstring>

namespace coloc::e57 {

static_assert(std::endian::native == std::endian::little, "e57io assumes a little-endian host");

template <typename T>
inline T load_le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

template <typename T>
inline void store_le(std::uint8_t* p, T v) {
  std::memcpy(p, &v, sizeof(T));
}

}  // namespace coloc::e57
