#pragma once
// Structural check of one OSC 1.0 message before liblo sees it. liblo 0.31's
// lo_message_deserialise trusts the type tags: a blob tag with no blob behind it ("/x\0\0,b\0\0")
// makes it read past the buffer (valgrind: invalid read in lo_validate_blob). So every byte an
// argument claims is checked here against the datagram first, and liblo only decodes messages
// whose layout is already known to be complete.

#include <cstddef>
#include <cstdint>
#include <string>

namespace coloc::fusion {

// Empty when `data[0, size)` is one complete OSC message: a '/' address and a ',' type-tag
// string (both zero-terminated and padded to 4 bytes), then exactly the bytes the tags call for
// (i f c r m: 4; h t d: 8; s S: padded string; b: int32 size + padded bytes; T F N I [ ]: none).
// Otherwise the reason, naming the byte offset. Pure; never reads outside the range.
std::string check_osc_message(const std::uint8_t* data, std::size_t size);

}  // namespace coloc::fusion
