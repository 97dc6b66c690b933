#include "e57io/compressed_vector_writer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "e57io/bytes.hpp"

namespace coloc::e57 {
namespace {

constexpr std::size_t kMaxPacket = 65536;
constexpr std::size_t kBatch = 4096;  // records encoded between packet flushes

unsigned word_size(const Codec& c) {
  if (c.kind == FieldKind::kFloat) return c.bits / 8;
  if (c.bits <= 8) return 1;
  if (c.bits <= 16) return 2;
  if (c.bits <= 32) return 4;
  return 8;
}

}  // namespace

CompressedVectorWriter::CompressedVectorWriter(PagedWriter& file, std::vector<Codec> codecs)
    : file_(file), packet_(kMaxPacket) {
  file_.align(4);
  start_ = file_.logical_position();
  file_.write_zeros(32);
  for (Codec& c : codecs) {
    Stream s;
    s.codec = c;
    s.word = word_size(c);
    streams_.push_back(std::move(s));
  }
}

void CompressedVectorWriter::put(Stream& s, std::uint64_t v) {
  const unsigned w = s.codec.bits;
  if (w == 0) return;
  s.acc |= v << s.acc_bits;
  if (s.acc_bits + w >= 64) {
    const std::size_t at = s.bytes.size();
    s.bytes.resize(at + 8);
    store_le<std::uint64_t>(s.bytes.data() + at, s.acc);
    const unsigned used = 64 - s.acc_bits;  // bits of v already in acc
    s.acc = used >= 64 ? 0 : v >> used;
    s.acc_bits = s.acc_bits + w - 64;
  } else {
    s.acc_bits += w;
  }
}

void CompressedVectorWriter::add_records(std::size_t n, const std::vector<const double*>& doubles,
                                         const std::vector<const std::int64_t*>& integers) {
  for (std::size_t begin = 0; begin < n; begin += kBatch) {
    const std::size_t end = std::min(n, begin + kBatch);
    for (std::size_t k = 0; k < streams_.size(); ++k) {
      Stream& s = streams_[k];
      const Codec& c = s.codec;
      for (std::size_t i = begin; i < end; ++i) {
        if (c.kind == FieldKind::kFloat) {
          if (c.bits == 32) {
            const float f = static_cast<float>(doubles[k][i]);
            std::uint32_t u;
            std::memcpy(&u, &f, 4);
            put(s, u);
          } else {
            std::uint64_t u;
            std::memcpy(&u, &doubles[k][i], 8);
            put(s, u);
          }
          continue;
        }
        std::int64_t raw;
        if (c.kind == FieldKind::kScaledInteger) {
          const double r = std::round((doubles[k][i] - c.offset) / c.scale);
          if (!(r >= -9.2e18 && r <= 9.2e18)) {
            throw Error("value " + std::to_string(doubles[k][i]) + " of record " +
                        std::to_string(records_ + i) + " cannot be scaled to an integer");
          }
          raw = static_cast<std::int64_t>(r);
        } else {
          raw = integers[k][i];
        }
        const std::uint64_t v =
            static_cast<std::uint64_t>(raw) - static_cast<std::uint64_t>(c.minimum);
        if (raw < c.minimum || v > c.range) {
          throw Error("value " + std::to_string(raw) + " of record " +
                      std::to_string(records_ + i) +
                      " lies outside the field's [minimum, maximum] = [" +
                      std::to_string(c.minimum) + ", " +
                      std::to_string(static_cast<std::int64_t>(
                          static_cast<std::uint64_t>(c.minimum) + c.range)) +
                      "]");
        }
        put(s, v);
      }
    }
    write_packets(false);
  }
  records_ += n;
}

void CompressedVectorWriter::write_packet(const std::vector<std::size_t>& take) {
  const std::size_t header = 6 + 2 * streams_.size();
  std::size_t length = header;
  for (std::size_t t : take)
    length += t;
  const std::size_t padded = (length + 3) / 4 * 4;
  std::uint8_t* p = packet_.data();  // kMaxPacket bytes
  std::memset(p, 0, padded);
  p[0] = 1;  // data packet
  p[1] = 0;  // flags
  store_le<std::uint16_t>(p + 2, static_cast<std::uint16_t>(padded - 1));
  store_le<std::uint16_t>(p + 4, static_cast<std::uint16_t>(streams_.size()));
  std::size_t pos = header;
  for (std::size_t k = 0; k < streams_.size(); ++k) {
    store_le<std::uint16_t>(p + 6 + 2 * k, static_cast<std::uint16_t>(take[k]));
    if (take[k] > 0) std::memcpy(p + pos, streams_[k].bytes.data(), take[k]);
    streams_[k].bytes.erase(streams_[k].bytes.begin(),
                            streams_[k].bytes.begin() + static_cast<std::ptrdiff_t>(take[k]));
    pos += take[k];
  }
  file_.write({p, padded});
}

void CompressedVectorWriter::write_packets(bool final) {
  const std::size_t capacity = kMaxPacket - 6 - 2 * streams_.size() - 3;
  for (;;) {
    std::size_t pending = 0;
    for (const Stream& s : streams_)
      pending += s.bytes.size();
    if (pending == 0 || (!final && pending < capacity)) return;
    std::vector<std::size_t> take(streams_.size());
    for (std::size_t k = 0; k < streams_.size(); ++k) {
      const Stream& s = streams_[k];
      std::size_t t = s.bytes.size();
      if (pending > capacity) {
        t = static_cast<std::size_t>(static_cast<double>(t) * static_cast<double>(capacity) /
                                     static_cast<double>(pending));
      }
      t -= t % s.word;  // whole register words per packet
      take[k] = t;
    }
    std::size_t total = 0;
    for (std::size_t t : take)
      total += t;
    if (total == 0) {
      // Streams with less than a word each: only possible when final (padded to words).
      for (std::size_t k = 0; k < streams_.size(); ++k)
        take[k] = streams_[k].bytes.size();
    }
    write_packet(take);
  }
}

void CompressedVectorWriter::finish() {
  if (finished_) return;
  finished_ = true;
  for (Stream& s : streams_) {
    while (s.acc_bits > 0) {
      s.bytes.push_back(static_cast<std::uint8_t>(s.acc));
      s.acc >>= 8;
      s.acc_bits = s.acc_bits > 8 ? s.acc_bits - 8 : 0;
    }
  }
  // Pad each stream to whole words: total bytes of stream = bytes written + pending.
  // Track via record count: total bits = records * bits.
  for (Stream& s : streams_) {
    const std::uint64_t total_bytes = (records_ * s.codec.bits + 7) / 8;
    const std::uint64_t padded = (total_bytes + s.word - 1) / s.word * s.word;
    s.bytes.resize(s.bytes.size() + static_cast<std::size_t>(padded - total_bytes), 0);
  }
  const std::uint64_t data_logical = start_ + 32;  // packets follow the header directly
  write_packets(true);
  if (records_ == 0) write_packet(std::vector<std::size_t>(streams_.size(), 0));
  const std::uint64_t end = file_.logical_position();
  std::uint8_t h[32] = {};
  h[0] = 1;  // compressed vector section
  store_le<std::uint64_t>(h + 8, end - start_);
  store_le<std::uint64_t>(h + 16, logical_to_physical(data_logical));
  store_le<std::uint64_t>(h + 24, 0);  // no index packets
  file_.patch(start_, h);
}

}  // namespace coloc::e57
