// Bit unpacking: the dispatching unpacker (the AVX2 kernel where the CPU has it) and the portable
// loop agree with a bit-by-bit reference for every width, start bit and length, tail included.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "e57io/bit_unpack.hpp"

namespace coloc::e57 {
namespace {

// The E57 definition, one bit at a time: bit i of the stream is bit i % 8 of byte i / 8.
std::uint32_t reference_value(const std::vector<std::uint8_t>& buf, std::uint64_t bit,
                              unsigned bits) {
  std::uint32_t v = 0;
  for (unsigned b = 0; b < bits; ++b) {
    const std::uint64_t at = bit + b;
    v |= static_cast<std::uint32_t>((buf[at / 8] >> (at % 8)) & 1u) << b;
  }
  return v;
}

TEST(E57BitUnpack, EveryWidthStartAndLengthMatchesTheReference) {
  std::mt19937 rng(57);
  constexpr std::size_t kMaxValues = 1100;
  std::vector<std::uint8_t> buf(kMaxValues * 4 + 8 + kUnpackPad, 0);
  for (auto& b : buf)
    b = static_cast<std::uint8_t>(rng());
  for (unsigned bits = 1; bits <= 32; ++bits) {
    for (const std::uint64_t start : {0u, 1u, 3u, 7u, 8u, 13u, 64u}) {
      for (const std::size_t n :
           {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{8}, std::size_t{9},
            std::size_t{16}, std::size_t{23}, std::size_t{kMaxValues}}) {
        // Only the values' bytes are data: what follows them must not change the result.
        std::vector<std::uint8_t> data(buf);
        const std::uint64_t end_byte = (start + std::uint64_t{bits} * n + 7) / 8;
        std::fill(data.begin() + static_cast<std::ptrdiff_t>(end_byte), data.end(), 0xFF);
        std::vector<std::uint32_t> fast(n + 1, 0xDEADBEEF), portable(n + 1, 0xDEADBEEF);
        const std::uint32_t fast_max = unpack_bits(data.data(), start, bits, n, fast.data());
        const std::uint32_t portable_max =
            unpack_bits_portable(data.data(), start, bits, n, portable.data());
        std::uint32_t want_max = 0;
        for (std::size_t i = 0; i < n; ++i) {
          const std::uint32_t want = reference_value(data, start + std::uint64_t{bits} * i, bits);
          want_max = std::max(want_max, want);
          ASSERT_EQ(fast[i], want) << "bits " << bits << " start " << start << " value " << i;
          ASSERT_EQ(portable[i], want) << "bits " << bits << " start " << start << " value " << i;
        }
        EXPECT_EQ(fast[n], 0xDEADBEEF) << "wrote past n";
        EXPECT_EQ(portable[n], 0xDEADBEEF) << "wrote past n";
        EXPECT_EQ(fast_max, want_max) << "bits " << bits << " start " << start << " n " << n;
        EXPECT_EQ(portable_max, want_max) << "bits " << bits << " start " << start << " n " << n;
      }
    }
  }
}

TEST(E57BitUnpack, AllOnesKeepsTheTopBit) {
  std::vector<std::uint8_t> data(64 + kUnpackPad, 0xFF);
  std::vector<std::uint32_t> out(16);
  for (unsigned bits : {1u, 8u, 22u, 25u, 31u, 32u}) {
    const std::uint32_t want = bits == 32 ? 0xFFFFFFFFu : (1u << bits) - 1;
    EXPECT_EQ(unpack_bits(data.data(), 5, bits, 16, out.data()), want) << bits;
    for (const std::uint32_t v : out)
      EXPECT_EQ(v, want) << bits;
  }
}

}  // namespace
}  // namespace coloc::e57
