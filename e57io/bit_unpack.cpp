#include "e57io/bit_unpack.hpp"

#include <algorithm>
#include <array>

#include "e57io/bytes.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define COLOC_E57_HAVE_AVX2_KERNEL 1
#endif

namespace coloc::e57 {
namespace {

#ifdef COLOC_E57_HAVE_AVX2_KERNEL
// Eight values per step. Starting byte-aligned plus `first` bits, eight values span exactly
// `bits` bytes, so every step has the same layout: values 0-3 lie in the 16 bytes from the step's
// first byte, values 4-7 in the 16 bytes from byte (first + 4 * bits) / 8 (at most 13 bytes of
// each are needed for bits <= 25). Each 128-bit lane gets its own load, a byte shuffle gathers
// the 4 bytes holding each value into a 32-bit lane, and a per-lane shift and mask finish it.
__attribute__((target("avx2"))) std::uint32_t unpack_avx2(const std::uint8_t* buf,
                                                          std::uint64_t bit, unsigned bits,
                                                          std::size_t n, std::uint32_t* out) {
  const std::uint8_t* p = buf + bit / 8;
  const auto first = static_cast<unsigned>(bit % 8);
  const unsigned high_lane_byte = (first + 4 * bits) / 8;
  alignas(32) std::array<std::uint8_t, 32> shuffle{};
  alignas(32) std::array<std::uint32_t, 8> shift{};
  for (unsigned j = 0; j < 8; ++j) {
    unsigned at = first + j * bits;  // bit position from p
    if (j >= 4) at -= 8 * high_lane_byte;
    const unsigned lane = j / 4;
    for (unsigned b = 0; b < 4; ++b)
      shuffle[16 * lane + 4 * (j % 4) + b] = static_cast<std::uint8_t>(at / 8 + b);
    shift[j] = at % 8;
  }
  const __m256i shuffle_v = _mm256_load_si256(reinterpret_cast<const __m256i*>(shuffle.data()));
  const __m256i shift_v = _mm256_load_si256(reinterpret_cast<const __m256i*>(shift.data()));
  const __m256i mask_v = _mm256_set1_epi32(static_cast<int>((1u << bits) - 1));
  __m256i max_v = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
    const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + high_lane_byte));
    __m256i v = _mm256_inserti128_si256(_mm256_castsi128_si256(lo), hi, 1);
    v = _mm256_shuffle_epi8(v, shuffle_v);
    v = _mm256_and_si256(_mm256_srlv_epi32(v, shift_v), mask_v);
    max_v = _mm256_max_epu32(max_v, v);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + i), v);
    p += bits;
  }
  alignas(32) std::array<std::uint32_t, 8> lanes{};
  _mm256_store_si256(reinterpret_cast<__m256i*>(lanes.data()), max_v);
  std::uint32_t max = *std::max_element(lanes.begin(), lanes.end());
  if (i < n) {
    max = std::max(max,
                   unpack_bits_portable(buf, bit + std::uint64_t{bits} * i, bits, n - i, out + i));
  }
  return max;
}

bool cpu_has_avx2() {
  return __builtin_cpu_supports("avx2");
}
#endif

}  // namespace

std::uint32_t unpack_bits_portable(const std::uint8_t* buf, std::uint64_t bit, unsigned bits,
                                   std::size_t n, std::uint32_t* out) {
  // A value of up to 32 bits plus a start of up to 7 bits fits one 64-bit load.
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  std::uint32_t max = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto v =
        static_cast<std::uint32_t>((load_le<std::uint64_t>(buf + (bit >> 3)) >> (bit & 7)) & mask);
    max = std::max(max, v);
    out[i] = v;
    bit += bits;
  }
  return max;
}

std::uint32_t unpack_bits(const std::uint8_t* buf, std::uint64_t bit, unsigned bits, std::size_t n,
                          std::uint32_t* out) {
#ifdef COLOC_E57_HAVE_AVX2_KERNEL
  // Asked each call: cheap (a cached flag in libgcc) and keeps us free of global state.
  if (bits <= 25 && n >= 8 && cpu_has_avx2()) return unpack_avx2(buf, bit, bits, n, out);
#endif
  return unpack_bits_portable(buf, bit, bits, n, out);
}

}  // namespace coloc::e57
