#pragma once
// The `metadata` table's key/value entries (internal to slam/mapdb). Keys (README "Map
// database"): format, coloc_version, saved_utc, vocabulary_checksum, vocabulary_words,
// settings, frame_name, frame_transform, registration (optional), first_keyframe, next_keyframe_id,
// next_point_id, count.<table> and checksum.<table> for every other table, and checksum.metadata
// over all entries that are not checksums.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "slam/mapdb/mapdb.hpp"

namespace coloc::slam::mapdb::detail {

using MetadataEntries = std::map<std::string, std::string>;

constexpr const char* kFormat = "coloc map";

// The entries MapMetadata defines (everything but ids, counts and checksums).
MetadataEntries metadata_entries(const MapMetadata& metadata);
// Throws coloc::Error naming the file and "metadata.<key>" for a missing or malformed entry.
MapMetadata parse_metadata(const MetadataEntries& entries, const std::filesystem::path& file);

// Checksum of the entries whose key does not start with "checksum.", in key order.
std::uint64_t metadata_checksum(const MetadataEntries& entries);

std::string hex64(std::uint64_t v);
// The entry `key`; throws naming the file and key when it is missing.
const std::string& entry(const MetadataEntries& entries, const std::string& key,
                         const std::filesystem::path& file);
// An unsigned decimal entry; throws naming the file and key when malformed.
std::uint64_t entry_u64(const MetadataEntries& entries, const std::string& key,
                        const std::filesystem::path& file);
// A hex64() entry.
std::uint64_t entry_hex64(const MetadataEntries& entries, const std::string& key,
                          const std::filesystem::path& file);

}  // namespace coloc::slam::mapdb::detail
