#pragma once
// Unpacking of E57 bit-packed integers (ASTM E2807 section 9.9: values of `bits` bits, least
// significant bit first, back to back). The hot loop of point reading: an AVX2 kernel turns eight
// values of up to 25 bits into 32-bit lanes with one shuffle and one shift when the CPU has AVX2
// (asked at run time; the build needs no -m flags), else a portable loop does the same.
// Thread-safe (pure functions).

#include <cstddef>
#include <cstdint>

namespace coloc::e57 {

// Bytes after the last value's first byte that the unpackers may read: callers keep that many
// readable (zero) bytes behind their data.
inline constexpr std::size_t kUnpackPad = 32;

// Writes the n values of `bits` bits (1..32) that start `bit` bits into buf to out[0..n) and
// returns the largest of them (0 when n is 0), so a caller checks a range once per call.
std::uint32_t unpack_bits(const std::uint8_t* buf, std::uint64_t bit, unsigned bits, std::size_t n,
                          std::uint32_t* out);

// The portable version (exposed so tests can compare both paths).
std::uint32_t unpack_bits_portable(const std::uint8_t* buf, std::uint64_t bit, unsigned bits,
                                   std::size_t n, std::uint32_t* out);

}  // namespace coloc::e57
