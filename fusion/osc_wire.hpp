#pragma once
// Structural check of one OSC 1.0 message before liblo sees it. liblo 0.31's
// lo_message_deserialise trusts the type tags: a blob tag with no blob behind it ("/x\0\0,b\0\0")
// makes it read past the buffer (valgrind: invalid read in lo_validate_blob). So every byte an
// argument claims is checked here against the datagram first, and liblo only decodes messages
// whose layout is already known to be complete.

#include <lo/lo.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>

#include "fusion/osc.hpp"

namespace coloc::fusion {

// Empty when `data[0, size)` is one complete OSC message: a '/' address and a ',' type-tag
// string (both zero-terminated and padded to 4 bytes), then exactly the bytes the tags call for
// (i f c r m: 4; h t d: 8; s S: padded string; b: int32 size + padded bytes; T F N I [ ]: none).
// Otherwise the reason, naming the byte offset. Pure; never reads outside the range.
std::string check_osc_message(const std::uint8_t* data, std::size_t size);

// Owns a liblo message (built to encode, or deserialised to decode).
struct LoMessageDeleter {
  void operator()(lo_message m) const { lo_message_free(m); }
};
using LoMessagePtr = std::unique_ptr<std::remove_pointer_t<lo_message>, LoMessageDeleter>;

// The first error met while decoding a datagram; later ones are ignored (the first names the
// cause, and the messages decoded before it are kept).
struct OscFailure {
  OscError error = OscError::kNone;
  std::string detail;
  void fail(OscError e, std::string why);
  bool failed() const { return error != OscError::kNone; }
};

// One message of a datagram, layout-checked and deserialised by liblo; valid during the visit.
struct OscMessageView {
  std::string address;
  std::string types;
  lo_message message = nullptr;
};

// Walks one datagram of at most `max_size` bytes: a message, or a bundle of them (nested at
// most 4 deep). Each message is checked (check_osc_message) before liblo deserialises it and
// `visit` sees it; a broken element is skipped and the walk goes on with the next (a bundle's
// other messages still count). Returns the first failure, the visitor's included. The one
// packet walk of both OSC decoders (fusion's and the session's): they differ in their addresses.
OscFailure walk_osc_packet(const std::uint8_t* data, std::size_t size, std::size_t max_size,
                           const std::function<void(const OscMessageView&, OscFailure&)>& visit);

// liblo's argument pointers point into the packet, 4-byte aligned, while lo_arg (a union with
// doubles) wants 8: read through memcpy instead of argv[i]->d.
template <typename T>
T read_osc_arg(const lo_arg* arg) {
  T value;
  std::memcpy(&value, static_cast<const void*>(arg), sizeof(T));
  return value;
}

// The ten arguments of a pose message (kPoseTypes) at argv[0..9]: false, with `failure` set,
// for non-finite values or a quaternion that is not (close to) unit; normalized otherwise.
bool read_osc_pose(lo_arg** argv, const std::string& address, PoseMessage& pose,
                   OscFailure& failure);

}  // namespace coloc::fusion
