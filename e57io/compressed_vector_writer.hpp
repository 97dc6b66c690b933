#pragma once
// Writing an E57 CompressedVector section: a 32-byte section header (patched at the end), then
// data packets of at most 64 KiB, each carrying a slice of every bytestream. Values are bit-packed
// LSB first (Integer/ScaledInteger: value - minimum in bit_width(maximum - minimum) bits; Float:
// IEEE little-endian). Every stream is padded to a whole number of its register word (1, 2, 4 or
// 8 bytes, by bit width) and each packet's slice is a multiple of that word, as libE57Format's
// decoders consume whole words. Memory: about one packet per stream.
//
// Internal to e57io. Not thread-safe.

#include <cstdint>
#include <vector>

#include "e57io/compressed_vector.hpp"
#include "e57io/paged_file.hpp"

namespace coloc::e57 {

class CompressedVectorWriter {
 public:
  // Writes the section header placeholder at the (4-byte aligned) current position.
  CompressedVectorWriter(PagedWriter& file, std::vector<Codec> codecs);

  // Appends n records; values[i] points at n values of channel i in the given type
  // (double for ScaledInteger/Float, int64 for Integer). Throws Error on an out-of-range value.
  void add_records(std::size_t n, const std::vector<const double*>& doubles,
                   const std::vector<const std::int64_t*>& integers);

  // Flushes, writes the last packets and patches the section header.
  void finish();

  std::uint64_t section_physical_offset() const { return logical_to_physical(start_); }
  std::uint64_t record_count() const { return records_; }

 private:
  struct Stream {
    Codec codec;
    unsigned word = 1;                // register word size in bytes
    std::vector<std::uint8_t> bytes;  // whole bytes not yet written
    std::uint64_t acc = 0;            // the low acc_bits bits are packed but not yet in `bytes`
    unsigned acc_bits = 0;
  };
  void put(Stream& s, std::uint64_t v);
  void write_packets(bool final);
  void write_packet(const std::vector<std::size_t>& take);

  PagedWriter& file_;
  std::vector<Stream> streams_;
  std::uint64_t start_ = 0;  // logical offset of the section header
  std::uint64_t records_ = 0;
  bool finished_ = false;
  std::vector<std::uint8_t> packet_;  // one packet being assembled
};

}  // namespace coloc::e57
