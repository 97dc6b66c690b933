#include "e57io/compressed_vector.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "e57io/bit_unpack.hpp"
#include "e57io/bytes.hpp"

namespace coloc::e57 {
namespace {

constexpr std::size_t kCacheSlots = 4;
constexpr std::size_t kPad = kUnpackPad;  // zero bytes after a channel's data: loads stay in bounds
constexpr std::uint8_t kIndexPacket = 0;
constexpr std::uint8_t kDataPacket = 1;
constexpr std::uint8_t kEmptyPacket = 2;

void collect_terminals(const Element& e, const std::string& prefix,
                       std::vector<const Element*>& out, std::vector<std::string>& names) {
  for (const Element& c : e.children) {
    const std::string name = prefix.empty() ? c.name : prefix + "/" + c.name;
    if (c.type == ElementType::kStructure || c.type == ElementType::kVector) {
      collect_terminals(c, name, out, names);
    } else {
      out.push_back(&c);
      names.push_back(name);
    }
  }
}

}  // namespace

Codec Codec::from_element(const Element& e) {
  Codec c;
  switch (e.type) {
    case ElementType::kInteger:
    case ElementType::kScaledInteger:
      c.kind = e.type == ElementType::kInteger ? FieldKind::kInteger : FieldKind::kScaledInteger;
      c.minimum = e.int_minimum;
      c.range =
          static_cast<std::uint64_t>(e.int_maximum) - static_cast<std::uint64_t>(e.int_minimum);
      c.bits = static_cast<unsigned>(std::bit_width(c.range));
      c.scale = e.scale;
      c.offset = e.offset;
      return c;
    case ElementType::kFloat:
      c.kind = FieldKind::kFloat;
      c.bits = e.single_precision ? 32 : 64;
      return c;
    default:
      throw Error(std::string("prototype element of type ") + to_string(e.type) +
                      " cannot be stored in a compressed vector",
                  {.element = e.path});
  }
}

Codec Codec::from_spec(const FieldSpec& spec) {
  Element e;
  e.type = spec.kind == FieldKind::kFloat     ? ElementType::kFloat
           : spec.kind == FieldKind::kInteger ? ElementType::kInteger
                                              : ElementType::kScaledInteger;
  e.int_minimum = spec.minimum;
  e.int_maximum = spec.maximum;
  e.scale = spec.scale;
  e.offset = spec.offset;
  e.single_precision = spec.single_precision;
  return from_element(e);
}

SectionHeader read_section_header(PagedReader& file, std::uint64_t physical_offset,
                                  const std::string& element) {
  const std::uint64_t logical = physical_to_logical(physical_offset);
  if (physical_offset % kPageSize >= kPageData || physical_offset < kHeaderSize ||
      logical + 32 > file.logical_length()) {
    throw Error("compressed vector section offset " + std::to_string(physical_offset) +
                    " is not a valid data offset in this file",
                {.file = file.path(),
                 .physical_offset = physical_offset,
                 .page = physical_offset / kPageSize,
                 .element = element});
  }
  std::uint8_t raw[32];
  file.read(logical, raw);
  if (raw[0] != 1) {
    throw file.error_at("invalid compressed vector section header: section id " +
                            std::to_string(raw[0]) + " (expected 1)",
                        logical, element);
  }
  for (int i = 1; i < 8; ++i) {
    if (raw[i] != 0) {
      throw file.error_at("invalid compressed vector section header: reserved bytes not zero",
                          logical, element);
    }
  }
  SectionHeader h;
  h.logical_start = logical;
  h.logical_length = load_le<std::uint64_t>(raw + 8);
  h.data_physical_offset = load_le<std::uint64_t>(raw + 16);
  h.index_physical_offset = load_le<std::uint64_t>(raw + 24);
  if (h.logical_length < 32 || h.logical_length > file.logical_length() - logical) {
    throw file.error_at(
        "invalid compressed vector section length " + std::to_string(h.logical_length), logical,
        element);
  }
  return h;
}

struct CompressedVectorReader::Channel {
  Codec codec;
  std::uint64_t next_packet = 0;  // logical offset of the next packet to take bytes from
  std::vector<std::uint8_t> buf;  // [0, end) valid bytes, then kPad zeros
  std::size_t end = 0;
  std::uint64_t bit = 0;  // bits consumed from buf[0]
  std::size_t done = 0;   // values decoded by the current read()
};

struct CompressedVectorReader::Packet {
  std::uint64_t logical = ~0ull;
  std::uint64_t last_use = 0;
  std::uint8_t type = 0;
  std::uint32_t length = 0;
  std::vector<std::uint8_t> bytes;  // the bytestream length table (data packets)
  std::vector<std::uint32_t> stream_begin, stream_size;  // from the packet's start
};

CompressedVectorReader::CompressedVectorReader(PagedReader& file, const Element& cv)
    : file_(file), element_(cv.path), record_count_(cv.record_count) {
  if (cv.type != ElementType::kCompressedVector) {
    throw Error("not a compressed vector", {.file = file.path(), .element = cv.path});
  }
  const Element* proto = cv.find("prototype");
  if (proto == nullptr) {
    throw Error("compressed vector has no prototype", {.file = file.path(), .element = cv.path});
  }
  if (const Element* codecs = cv.find("codecs"); codecs != nullptr && !codecs->children.empty()) {
    // Only bitPackCodec exists in E57 1.0; an explicit one is fine, anything else is not.
    for (const Element& c : codecs->children) {
      if (c.find("bitPackCodec") == nullptr) {
        throw Error("unsupported codec (only bitPackCodec is defined)",
                    {.file = file.path(), .element = c.path});
      }
    }
  }
  std::vector<const Element*> terminals;
  if (proto->type == ElementType::kStructure || proto->type == ElementType::kVector) {
    collect_terminals(*proto, "", terminals, names_);
  } else {
    terminals.push_back(proto);
    names_.push_back(proto->name);
  }
  section_ = read_section_header(file, cv.file_offset, cv.path);
  channels_.resize(terminals.size());
  std::uint64_t first_packet = 0;
  if (record_count_ > 0) {
    const std::uint64_t d = section_.data_physical_offset;
    first_packet = physical_to_logical(d);
    if (d % kPageSize >= kPageData || first_packet < section_.logical_start + 32 ||
        first_packet >= section_.logical_start + section_.logical_length) {
      throw file.error_at("data packet offset " + std::to_string(d) + " lies outside its section",
                          section_.logical_start + 16, cv.path);
    }
  }
  for (std::size_t i = 0; i < terminals.size(); ++i) {
    channels_[i].codec = Codec::from_element(*terminals[i]);
    channels_[i].next_packet = first_packet;
    channels_[i].buf.assign(kPad, 0);
  }
  // Each channel's bits must fit in the section: catches absurd record counts up front.
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    const unsigned bits = channels_[i].codec.bits;
    if (bits > 0 && record_count_ > section_.logical_length * 8 / bits) {
      throw file.error_at("recordCount " + std::to_string(record_count_) + " cannot fit in a " +
                              std::to_string(section_.logical_length) + "-byte section",
                          section_.logical_start, cv.path);
    }
  }
  cache_.resize(kCacheSlots);
}

CompressedVectorReader::~CompressedVectorReader() = default;

std::size_t CompressedVectorReader::channel_count() const {
  return channels_.size();
}

const Codec& CompressedVectorReader::channel_codec(std::size_t i) const {
  return channels_.at(i).codec;
}

const CompressedVectorReader::Packet& CompressedVectorReader::packet_at(std::uint64_t logical) {
  ++cache_clock_;
  for (Packet& p : cache_) {
    if (p.logical == logical) {
      p.last_use = cache_clock_;
      return p;
    }
  }
  Packet& p = *std::min_element(cache_.begin(), cache_.end(), [](const Packet& a, const Packet& b) {
    return a.last_use < b.last_use;
  });
  p.logical = ~0ull;  // invalid until fully parsed
  const std::uint64_t section_end = section_.logical_start + section_.logical_length;
  if (logical + 4 > section_end) {
    throw file_.error_at("compressed vector data ends before its " + std::to_string(record_count_) +
                             " records are complete",
                         logical, element_);
  }
  std::uint8_t head[4];
  file_.read(logical, head);
  p.type = head[0];
  p.length = std::uint32_t{load_le<std::uint16_t>(head + 2)} + 1;
  if (p.type != kDataPacket && p.type != kIndexPacket && p.type != kEmptyPacket) {
    throw file_.error_at("unknown packet type " + std::to_string(p.type), logical, element_);
  }
  if (p.length < 4 || logical + p.length > section_end) {
    throw file_.error_at("packet length " + std::to_string(p.length) + " is invalid", logical,
                         element_);
  }
  p.stream_begin.clear();
  p.stream_size.clear();
  if (p.type == kDataPacket) {
    // Only the header and the bytestream length table are read here; each channel copies its
    // slice straight from the file (one copy of the data instead of two).
    if (p.length < 6) throw file_.error_at("data packet too short", logical, element_);
    std::uint8_t count_raw[2];
    file_.read(logical + 4, count_raw);
    const std::uint32_t count = load_le<std::uint16_t>(count_raw);
    std::uint32_t pos = 6 + 2 * count;
    if (pos > p.length) {
      throw file_.error_at("data packet header longer than the packet", logical, element_);
    }
    p.bytes.resize(2 * count);
    file_.read(logical + 6, p.bytes);
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t n = load_le<std::uint16_t>(p.bytes.data() + 2 * i);
      if (pos + n > p.length) {
        throw file_.error_at("bytestream " + std::to_string(i) + " runs past its data packet",
                             logical, element_);
      }
      p.stream_begin.push_back(pos);
      p.stream_size.push_back(n);
      pos += n;
    }
  }
  p.logical = logical;
  p.last_use = cache_clock_;
  return p;
}

void CompressedVectorReader::refill(Channel& c) {
  const auto index = static_cast<std::size_t>(&c - channels_.data());
  for (;;) {
    const std::uint64_t at = c.next_packet;
    const Packet& p = packet_at(at);
    c.next_packet = at + p.length;
    if (p.type != kDataPacket || index >= p.stream_size.size() || p.stream_size[index] == 0) {
      continue;  // index/empty packets and packets without bytes for this stream
    }
    // Drop consumed whole bytes, then append this packet's slice.
    const std::size_t drop = static_cast<std::size_t>(c.bit / 8);
    std::memmove(c.buf.data(), c.buf.data() + drop, c.end - drop);
    c.end -= drop;
    c.bit -= drop * 8;
    const std::uint32_t n = p.stream_size[index];
    c.buf.resize(c.end + n + kPad);
    file_.read(at + p.stream_begin[index], {c.buf.data() + c.end, n});
    c.end += n;
    std::memset(c.buf.data() + c.end, 0, kPad);
    return;
  }
}

namespace {

template <typename T>
struct Decoder {
  static void run(const Codec& codec, const std::uint8_t* buf, std::uint64_t& bit, T* out,
                  std::size_t n, bool& out_of_range) {
    if (codec.kind == FieldKind::kFloat) {
      const std::uint8_t* p = buf + bit / 8;  // floats are byte aligned (32/64 bits each)
      if (codec.bits == 32) {
        for (std::size_t i = 0; i < n; ++i)
          out[i] = static_cast<T>(load_le<float>(p + 4 * i));
      } else {
        for (std::size_t i = 0; i < n; ++i)
          out[i] = static_cast<T>(load_le<double>(p + 8 * i));
      }
      bit += std::uint64_t{codec.bits} * n;
      return;
    }
    const unsigned bits = codec.bits;
    const std::uint64_t range = codec.range;
    bool bad = false;
    if (bits == 0) {
      for (std::size_t i = 0; i < n; ++i)
        out[i] = convert(codec, codec.minimum);
      return;
    }
    if (bits <= 32) {
      run_narrow(codec, buf, bit, out, n, out_of_range);
      return;
    }
    if (bits <= 57) {
      const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
      std::uint64_t b = bit;
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t v = (load_le<std::uint64_t>(buf + (b >> 3)) >> (b & 7)) & mask;
        bad |= v > range;
        out[i] = convert(codec, codec.minimum + static_cast<std::int64_t>(v));
        b += bits;
      }
      bit = b;
    } else {
      const std::uint64_t mask = bits == 64 ? ~0ull : (std::uint64_t{1} << bits) - 1;
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t lo = load_le<std::uint64_t>(buf + (bit >> 3));
        const unsigned s = static_cast<unsigned>(bit & 7);
        std::uint64_t v = lo >> s;
        if (s != 0) v |= std::uint64_t{buf[(bit >> 3) + 8]} << (64 - s);
        v &= mask;
        bad |= v > range;
        out[i] = convert(codec,
                         static_cast<std::int64_t>(static_cast<std::uint64_t>(codec.minimum) + v));
        bit += bits;
      }
    }
    out_of_range |= bad;
  }

  // Values of up to 32 bits: unpacked a block at a time into 32-bit integers (the vector kernel's
  // job), range-checked once per block, then converted in a loop the compiler vectorises. When
  // every value fits an int32 the conversion stays in 32-bit lanes; the results are the same
  // as convert()'s, value for value.
  static void run_narrow(const Codec& codec, const std::uint8_t* buf, std::uint64_t& bit, T* out,
                         std::size_t n, bool& out_of_range) {
    constexpr std::size_t kBlock = 1024;
    std::uint32_t raw[kBlock];
    const unsigned bits = codec.bits;
    const bool int32_values = codec.minimum >= std::numeric_limits<std::int32_t>::min() &&
                              codec.minimum + static_cast<std::int64_t>(codec.range) <=
                                  std::numeric_limits<std::int32_t>::max();
    const bool scaled = codec.kind == FieldKind::kScaledInteger;
    const double scale = codec.scale;
    const double offset = codec.offset;
    const std::int64_t minimum = codec.minimum;
    // Unsigned 32-bit addition wraps, so raw + minimum lands on the (int32) value exactly.
    const auto minimum32 = static_cast<std::uint32_t>(minimum);
    for (std::size_t at = 0; at < n; at += kBlock) {
      const std::size_t k = std::min(kBlock, n - at);
      const std::uint32_t max = unpack_bits(buf, bit, bits, k, raw);
      bit += std::uint64_t{bits} * k;
      if (max > codec.range) {
        out_of_range = true;
        return;
      }
      T* o = out + at;
      if (int32_values && scaled) {
        for (std::size_t i = 0; i < k; ++i)
          o[i] = static_cast<T>(
              static_cast<double>(static_cast<std::int32_t>(raw[i] + minimum32)) * scale + offset);
      } else if (int32_values) {
        for (std::size_t i = 0; i < k; ++i)
          o[i] = static_cast<T>(static_cast<std::int32_t>(raw[i] + minimum32));
      } else if (scaled) {
        for (std::size_t i = 0; i < k; ++i)
          o[i] =
              static_cast<T>(static_cast<double>(minimum + std::int64_t{raw[i]}) * scale + offset);
      } else {
        for (std::size_t i = 0; i < k; ++i)
          o[i] = static_cast<T>(minimum + std::int64_t{raw[i]});
      }
    }
  }

  static T convert(const Codec& codec, std::int64_t raw) {
    if (codec.kind == FieldKind::kScaledInteger) {
      return static_cast<T>(static_cast<double>(raw) * codec.scale + codec.offset);
    }
    return static_cast<T>(raw);
  }
};

template <typename T>
void decode_into(const Codec& codec, const std::uint8_t* buf, std::uint64_t& bit, void* out,
                 std::size_t offset, std::size_t n, bool& bad) {
  Decoder<T>::run(codec, buf, bit, static_cast<T*>(out) + offset, n, bad);
}

}  // namespace

bool CompressedVectorReader::decode_buffered(Channel& c, const Sink& sink, std::size_t n) {
  const unsigned bits = c.codec.bits;
  std::size_t k = n - c.done;
  if (bits > 0) {
    std::uint64_t avail = std::uint64_t{c.end} * 8 - c.bit;
    while (avail < bits) {  // a value may straddle packets, or a slice may be empty
      refill(c);
      avail = std::uint64_t{c.end} * 8 - c.bit;
    }
    k = static_cast<std::size_t>(std::min<std::uint64_t>(k, avail / bits));
  }
  bool bad = false;
  const std::size_t done = c.done;
  switch (sink.type) {
    case Sink::Type::kDouble:
      decode_into<double>(c.codec, c.buf.data(), c.bit, sink.data, done, k, bad);
      break;
    case Sink::Type::kFloat:
      decode_into<float>(c.codec, c.buf.data(), c.bit, sink.data, done, k, bad);
      break;
    case Sink::Type::kInt8:
      decode_into<std::int8_t>(c.codec, c.buf.data(), c.bit, sink.data, done, k, bad);
      break;
    case Sink::Type::kInt32:
      decode_into<std::int32_t>(c.codec, c.buf.data(), c.bit, sink.data, done, k, bad);
      break;
    case Sink::Type::kInt64:
      decode_into<std::int64_t>(c.codec, c.buf.data(), c.bit, sink.data, done, k, bad);
      break;
    case Sink::Type::kNone:
      c.done = n;
      return true;
  }
  if (bad) {
    throw file_.error_at("bytestream " + std::to_string(&c - channels_.data()) +
                             " holds a value outside its prototype's [minimum, maximum]",
                         c.next_packet, element_);
  }
  c.done += k;
  return c.done == n;
}

std::size_t CompressedVectorReader::read(std::size_t n, std::span<const Sink> sinks) {
  if (sinks.size() != channels_.size()) {
    throw Error("read() needs one sink per channel", {.file = file_.path(), .element = element_});
  }
  n = static_cast<std::size_t>(std::min<std::uint64_t>(n, record_count_ - records_read_));
  if (n == 0) return 0;
  // The channels take turns, each decoding what it holds (about one packet's slice) before the
  // next: so they walk the packets together and each packet is read, checked and parsed once.
  // Decoding one channel's n values at a time would run it many packets ahead of the others,
  // out of the packet cache, and read every packet again for every channel.
  for (Channel& c : channels_)
    c.done = 0;
  for (bool pending = true; pending;) {
    pending = false;
    for (std::size_t i = 0; i < channels_.size(); ++i) {
      if (sinks[i].type == Sink::Type::kNone || channels_[i].done == n) continue;
      if (!decode_buffered(channels_[i], sinks[i], n)) pending = true;
    }
  }
  records_read_ += n;
  return n;
}

}  // namespace coloc::e57
