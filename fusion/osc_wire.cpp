#include "fusion/osc_wire.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>

namespace coloc::fusion {
namespace {

std::size_t padded(std::size_t n) {
  return (n + 3) & ~std::size_t{3};
}

// Length of the padded OSC string starting at `offset` (terminator and padding included), or
// nullopt when it has no terminator within the data or its padding runs past the end.
std::optional<std::size_t> osc_string_length(const std::uint8_t* data, std::size_t size,
                                             std::size_t offset) {
  const void* end = std::memchr(data + offset, 0, size - offset);
  if (end == nullptr) return std::nullopt;
  const auto length =
      static_cast<std::size_t>(static_cast<const std::uint8_t*>(end) - data) - offset + 1;
  const std::size_t total = padded(length);
  if (total > size - offset) return std::nullopt;
  return total;
}

std::string at(std::size_t offset, const std::string& what) {
  return what + " at byte " + std::to_string(offset);
}

// Bytes the argument of type `tag` at `offset` takes, or nullopt (with `error` set).
std::optional<std::size_t> argument_size(char tag, const std::uint8_t* data, std::size_t size,
                                         std::size_t offset, std::string& error) {
  const std::size_t left = size - offset;
  switch (tag) {
    case 'i':
    case 'f':
    case 'c':
    case 'r':
    case 'm':
      if (left < 4) break;
      return 4;
    case 'h':
    case 't':
    case 'd':
      if (left < 8) break;
      return 8;
    case 's':
    case 'S':
      if (const auto n = osc_string_length(data, size, offset)) return n;
      error = at(offset, std::string("unterminated string argument '") + tag + "'");
      return std::nullopt;
    case 'b': {
      if (left < 4) break;
      const std::uint32_t n = (std::uint32_t{data[offset]} << 24) |
                              (std::uint32_t{data[offset + 1]} << 16) |
                              (std::uint32_t{data[offset + 2]} << 8) | data[offset + 3];
      if (n > left - 4 || padded(n) > left - 4) {
        error = at(offset, "blob of " + std::to_string(n) + " bytes overruns the message");
        return std::nullopt;
      }
      return 4 + padded(n);
    }
    case 'T':
    case 'F':
    case 'N':
    case 'I':
    case '[':
    case ']':
      return 0;
    default:
      error = at(offset, std::string("unknown type tag '") + tag + "'");
      return std::nullopt;
  }
  error = at(offset, std::string("argument '") + tag + "' cut off");
  return std::nullopt;
}

}  // namespace

std::string check_osc_message(const std::uint8_t* data, std::size_t size) {
  if (size == 0 || data[0] != '/') return "address does not start with '/'";
  const auto address = osc_string_length(data, size, 0);
  if (!address) return "address not terminated within the message";
  std::size_t offset = *address;
  if (offset >= size || data[offset] != ',') return at(offset, "type tag string missing");
  const auto tags = osc_string_length(data, size, offset);
  if (!tags) return at(offset, "type tag string not terminated");
  const std::size_t tag_begin = offset + 1;
  offset += *tags;
  for (std::size_t t = tag_begin; data[t] != 0; ++t) {
    std::string error;
    const auto n = argument_size(static_cast<char>(data[t]), data, size, offset, error);
    if (!n) return error;
    offset += *n;
  }
  if (offset != size)
    return at(offset, std::to_string(size - offset) + " bytes after the arguments");
  return {};
}

void OscFailure::fail(OscError e, std::string why) {
  if (failed()) return;
  error = e;
  detail = std::move(why);
}

namespace {

constexpr int kMaxBundleDepth = 4;

using Visitor = std::function<void(const OscMessageView&, OscFailure&)>;

std::uint32_t read_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

void walk_message(const std::uint8_t* data, std::size_t size, const Visitor& visit,
                  OscFailure& failure) {
  // liblo wants a mutable buffer; copy so the caller's packet stays untouched.
  std::array<std::uint8_t, 4096> copy{};
  if (size > copy.size()) {
    failure.fail(OscError::kOversized, "message larger than 4096 bytes");
    return;
  }
  // liblo reads whatever the type tags promise; it only gets messages whose every argument is
  // known to lie inside the datagram.
  if (const std::string reason = check_osc_message(data, size); !reason.empty()) {
    failure.fail(OscError::kMalformed, "not an OSC message: " + reason);
    return;
  }
  std::memcpy(copy.data(), data, size);
  int code = 0;
  const LoMessagePtr m(lo_message_deserialise(copy.data(), size, &code));
  if (!m) {
    failure.fail(OscError::kMalformed,
                 "not an OSC message (liblo error " + std::to_string(code) + ")");
    return;
  }
  OscMessageView view;
  view.address = lo_get_path(copy.data(), static_cast<ssize_t>(size));
  view.types = lo_message_get_types(m.get());
  view.message = m.get();
  visit(view, failure);
}

void walk_element(const std::uint8_t* data, std::size_t size, int depth, const Visitor& visit,
                  OscFailure& failure) {
  static constexpr char kBundleTag[] = "#bundle";  // 8 bytes with its terminating zero
  if (size < 8 || size % 4 != 0) {
    failure.fail(OscError::kMalformed,
                 "size " + std::to_string(size) + " is not a positive multiple of 4");
    return;
  }
  if (std::memcmp(data, kBundleTag, 8) != 0) {
    walk_message(data, size, visit, failure);
    return;
  }
  if (depth >= kMaxBundleDepth) {
    failure.fail(OscError::kMalformed, "bundles nested too deeply");
    return;
  }
  std::size_t offset = 16;  // "#bundle\0" + 8-byte timetag
  if (size < offset) {
    failure.fail(OscError::kMalformed, "bundle shorter than its header");
    return;
  }
  while (offset < size) {
    if (size - offset < 4) {
      failure.fail(OscError::kMalformed, "bundle element size cut off");
      return;
    }
    const std::size_t element = read_be32(data + offset);
    offset += 4;
    if (element > size - offset) {
      failure.fail(OscError::kMalformed,
                   "bundle element of " + std::to_string(element) + " bytes overruns the packet");
      return;
    }
    walk_element(data + offset, element, depth + 1, visit, failure);
    offset += element;
  }
}

}  // namespace

OscFailure walk_osc_packet(const std::uint8_t* data, std::size_t size, std::size_t max_size,
                           const Visitor& visit) {
  OscFailure failure;
  if (size > max_size) {
    failure.fail(OscError::kOversized, "packet of " + std::to_string(size) + " bytes exceeds " +
                                           std::to_string(max_size));
    return failure;
  }
  walk_element(data, size, 0, visit, failure);
  return failure;
}

bool read_osc_pose(lo_arg** argv, const std::string& address, PoseMessage& p, OscFailure& failure) {
  p.time = read_osc_arg<double>(argv[0]);
  p.sequence = read_osc_arg<std::int32_t>(argv[1]);
  p.state = read_osc_arg<std::int32_t>(argv[2]);
  p.position = {read_osc_arg<float>(argv[3]), read_osc_arg<float>(argv[4]),
                read_osc_arg<float>(argv[5])};
  Eigen::Vector4d q(read_osc_arg<float>(argv[6]), read_osc_arg<float>(argv[7]),
                    read_osc_arg<float>(argv[8]), read_osc_arg<float>(argv[9]));
  if (!std::isfinite(p.time) || !p.position.allFinite() || !q.allFinite()) {
    failure.fail(OscError::kInvalidValue, address + ": non-finite value");
    return false;
  }
  // float32 quaternions from engines are unit to ~1e-7; anything far off is a bug upstream.
  if (std::abs(q.norm() - 1.0) > 1e-2) {
    failure.fail(OscError::kInvalidValue,
                 address + ": quaternion norm " + std::to_string(q.norm()) + " is not 1");
    return false;
  }
  q.normalize();
  p.orientation = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
  return true;
}

}  // namespace coloc::fusion
