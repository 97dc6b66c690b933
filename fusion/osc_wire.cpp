#include "fusion/osc_wire.hpp"

#include <cstring>
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

}  // namespace coloc::fusion
