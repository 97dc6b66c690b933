#pragma once
// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), the checksum of every E57 page.
// Uses the SSE4.2 crc32 instruction when the CPU has it, else slicing-by-8 tables.
// Thread-safe (pure functions; the tables are compile-time constants).

#include <cstddef>
#include <cstdint>

namespace coloc::e57 {

// Continues a CRC: pass the previous result as `crc` (0 to start). crc32c("123456789") ==
// 0xE3069283.
std::uint32_t crc32c(const void* data, std::size_t size, std::uint32_t crc = 0);

// CRCs (from 0) of three equal-length buffers at once: the hardware instruction has a 3-cycle
// latency and 1-cycle throughput, so three independent chains run ~3x faster than one.
void crc32c_x3(const void* a, const void* b, const void* c, std::size_t size, std::uint32_t out[3]);

// The portable table-driven version (exposed so tests can compare both paths).
std::uint32_t crc32c_portable(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace coloc::e57
