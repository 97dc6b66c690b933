#pragma once
// Private to coloc_capture: little-endian reads and writes of the camera's binary structures
// (metadata, calibration tables, hardware-monitor commands), bounds-checked.
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "slam/core/error.hpp"

namespace coloc::capture::detail {

template <typename T>
T read_le(std::span<const std::uint8_t> bytes, std::size_t offset, const std::string& what) {
  if (offset + sizeof(T) > bytes.size())
    throw Error(what + ": needs " + std::to_string(offset + sizeof(T)) + " bytes, has " +
                    std::to_string(bytes.size()),
                {.offset = offset});
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));  // the host is little-endian (x86, ARM)
  return value;
}

template <typename T>
void append_le(std::vector<std::uint8_t>& out, T value) {
  const std::size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

template <typename T>
void write_le(std::vector<std::uint8_t>& out, std::size_t offset, T value) {
  if (out.size() < offset + sizeof(T)) out.resize(offset + sizeof(T), 0);
  std::memcpy(out.data() + offset, &value, sizeof(T));
}

}  // namespace coloc::capture::detail
