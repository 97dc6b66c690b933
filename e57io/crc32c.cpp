#include "e57io/crc32c.hpp"

#include <array>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <nmmintrin.h>
#define COLOC_E57_HAVE_SSE42 1
#endif

namespace coloc::e57 {
namespace {

constexpr std::uint32_t kPoly = 0x82F63B78u;

using Tables = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr Tables make_tables() {
  Tables t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k)
      c = (c & 1u) ? (c >> 1) ^ kPoly : c >> 1;
    t[0][i] = c;
  }
  for (std::uint32_t i = 0; i < 256; ++i) {
    for (int s = 1; s < 8; ++s)
      t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
  }
  return t;
}

constexpr Tables kTables = make_tables();

#ifdef COLOC_E57_HAVE_SSE42
__attribute__((target("sse4.2"))) std::uint32_t crc32c_hw(const unsigned char* p, std::size_t n,
                                                          std::uint32_t crc) {
  std::uint64_t c = ~crc;
  while (n >= 8) {
    std::uint64_t v;
    std::memcpy(&v, p, 8);
    c = _mm_crc32_u64(c, v);
    p += 8;
    n -= 8;
  }
  auto c32 = static_cast<std::uint32_t>(c);
  while (n-- > 0)
    c32 = _mm_crc32_u8(c32, *p++);
  return ~c32;
}

__attribute__((target("sse4.2"))) void crc32c_hw_x3(const unsigned char* a, const unsigned char* b,
                                                    const unsigned char* c, std::size_t n,
                                                    std::uint32_t out[3]) {
  std::uint64_t ca = 0xFFFFFFFFu, cb = 0xFFFFFFFFu, cc = 0xFFFFFFFFu;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t va, vb, vc;
    std::memcpy(&va, a + i, 8);
    std::memcpy(&vb, b + i, 8);
    std::memcpy(&vc, c + i, 8);
    ca = _mm_crc32_u64(ca, va);
    cb = _mm_crc32_u64(cb, vb);
    cc = _mm_crc32_u64(cc, vc);
  }
  auto a32 = static_cast<std::uint32_t>(ca), b32 = static_cast<std::uint32_t>(cb),
       c32 = static_cast<std::uint32_t>(cc);
  for (; i < n; ++i) {
    a32 = _mm_crc32_u8(a32, a[i]);
    b32 = _mm_crc32_u8(b32, b[i]);
    c32 = _mm_crc32_u8(c32, c[i]);
  }
  out[0] = ~a32;
  out[1] = ~b32;
  out[2] = ~c32;
}

bool cpu_has_sse42() {
  return __builtin_cpu_supports("sse4.2");
}
#endif

}  // namespace

std::uint32_t crc32c_portable(const void* data, std::size_t size, std::uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint32_t c = ~crc;
  while (size >= 8) {
    std::uint32_t lo;
    std::uint32_t hi;
    std::memcpy(&lo, p, 4);  // E57 is little-endian only; so are our targets
    std::memcpy(&hi, p + 4, 4);
    lo ^= c;
    c = kTables[7][lo & 0xFF] ^ kTables[6][(lo >> 8) & 0xFF] ^ kTables[5][(lo >> 16) & 0xFF] ^
        kTables[4][lo >> 24] ^ kTables[3][hi & 0xFF] ^ kTables[2][(hi >> 8) & 0xFF] ^
        kTables[1][(hi >> 16) & 0xFF] ^ kTables[0][hi >> 24];
    p += 8;
    size -= 8;
  }
  while (size-- > 0)
    c = (c >> 8) ^ kTables[0][(c ^ *p++) & 0xFF];
  return ~c;
}

std::uint32_t crc32c(const void* data, std::size_t size, std::uint32_t crc) {
#ifdef COLOC_E57_HAVE_SSE42
  // Asked each call: cheap (a cached flag in libgcc) and keeps us free of global state.
  if (cpu_has_sse42()) return crc32c_hw(static_cast<const unsigned char*>(data), size, crc);
#endif
  return crc32c_portable(data, size, crc);
}

void crc32c_x3(const void* a, const void* b, const void* c, std::size_t size,
               std::uint32_t out[3]) {
#ifdef COLOC_E57_HAVE_SSE42
  if (cpu_has_sse42()) {
    crc32c_hw_x3(static_cast<const unsigned char*>(a), static_cast<const unsigned char*>(b),
                 static_cast<const unsigned char*>(c), size, out);
    return;
  }
#endif
  out[0] = crc32c_portable(a, size);
  out[1] = crc32c_portable(b, size);
  out[2] = crc32c_portable(c, size);
}

}  // namespace coloc::e57
