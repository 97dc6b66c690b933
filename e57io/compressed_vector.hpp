#pragma once
// Reading an E57 CompressedVector (ASTM E2807 section 9.7-9.9): a 32-byte section header, then
// data packets (plus index and empty packets, which are skipped). Each packet carries a slice of
// every bytestream; stream i holds the bit-packed values of the i-th terminal prototype element
// and continues across packets. Each stream ("channel") is followed through the packets on its
// own, so unbalanced writers cost no extra memory. read() lets the channels take turns a packet
// slice at a time, so on balanced files they walk the packets together: a small cache of packet
// headers and the file's read window then see each packet once. Memory: one packet slice of
// bytes per channel, the headers of 4 packets, and the file's 64 KiB window.
//
// Internal to e57io (used by PointStream and by the grouping reader). Not thread-safe.

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "e57io/element.hpp"
#include "e57io/paged_file.hpp"
#include "e57io/types.hpp"

namespace coloc::e57 {

// Decoding parameters of one terminal prototype element.
struct Codec {
  FieldKind kind = FieldKind::kFloat;
  unsigned bits = 64;  // Integer/ScaledInteger: bit width of (raw - minimum); Float: 32 or 64
  std::int64_t minimum = 0;
  std::uint64_t range = 0;  // maximum - minimum (Integer/ScaledInteger)
  double scale = 1.0;
  double offset = 0.0;

  static Codec from_element(const Element& e);  // throws Error for non-numeric elements
  static Codec from_spec(const FieldSpec& spec);
};

// Destination of one channel's values for one read() call.
struct Sink {
  enum class Type : std::uint8_t { kNone, kDouble, kFloat, kInt8, kInt32, kInt64 };
  Type type = Type::kNone;  // kNone: the channel is not decoded (and its bytes never read)
  void* data = nullptr;     // array of at least n values of `type`
};

struct SectionHeader {
  std::uint64_t logical_start = 0;
  std::uint64_t logical_length = 0;
  std::uint64_t data_physical_offset = 0;
  std::uint64_t index_physical_offset = 0;
};

// Parses and validates the 32-byte section header at `physical_offset`. Throws Error naming the
// offset and `element` when the id, reserved bytes or offsets are invalid.
SectionHeader read_section_header(PagedReader& file, std::uint64_t physical_offset,
                                  const std::string& element);

class CompressedVectorReader {
 public:
  // `cv` must be a CompressedVector element; the reader keeps no reference to it.
  CompressedVectorReader(PagedReader& file, const Element& cv);
  ~CompressedVectorReader();
  CompressedVectorReader(const CompressedVectorReader&) = delete;
  CompressedVectorReader& operator=(const CompressedVectorReader&) = delete;

  std::uint64_t record_count() const { return record_count_; }
  std::uint64_t records_read() const { return records_read_; }
  std::size_t channel_count() const;
  // Terminal prototype elements in bytestream order (name path relative to the prototype).
  const std::vector<std::string>& channel_names() const { return names_; }
  const Codec& channel_codec(std::size_t i) const;

  // Decodes the next min(n, remaining) records into sinks (one per channel; size must equal
  // channel_count()). Returns the number of records decoded, 0 at the end.
  std::size_t read(std::size_t n, std::span<const Sink> sinks);

 private:
  struct Channel;
  struct Packet;
  const Packet& packet_at(std::uint64_t logical);
  void refill(Channel& c);
  // Decodes the values of channel c already buffered (refilling first if it holds less than
  // one), up to n in all for this read(); true when all n are done.
  bool decode_buffered(Channel& c, const Sink& sink, std::size_t n);

  PagedReader& file_;
  std::string element_;
  std::uint64_t record_count_ = 0;
  std::uint64_t records_read_ = 0;
  SectionHeader section_;
  std::vector<std::string> names_;
  std::vector<Channel> channels_;
  std::vector<Packet> cache_;
  std::uint64_t cache_clock_ = 0;
};

}  // namespace coloc::e57
