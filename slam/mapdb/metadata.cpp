#include "slam/mapdb/metadata.hpp"

#include <charconv>
#include <cstdio>
#include <sstream>

#include "slam/core/error.hpp"
#include "slam/mapdb/sqlite.hpp"

namespace coloc::slam::mapdb::detail {

namespace {

[[noreturn]] void bad_entry(const std::filesystem::path& file, const std::string& key,
                            const std::string& message) {
  throw Error(message, {.file = file.string(), .field = "metadata." + key});
}

// %.17g: enough digits that strtod gives back the same double.
std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// "s qx qy qz qw tx ty tz" of frame_from_slam.
std::string sim3_text(const Sim3& t) {
  const Eigen::Quaterniond& q = t.so3().quaternion();
  std::string s = exact(t.scale());
  for (double v : {q.x(), q.y(), q.z(), q.w(), t.translation().x(), t.translation().y(),
                   t.translation().z()}) {
    s += ' ';  // append, not operator+: GCC 12 false -Wrestrict (bug 105329)
    s += exact(v);
  }
  return s;
}

Sim3 parse_sim3(const std::string& text, const std::filesystem::path& file) {
  std::istringstream in(text);
  double v[8];
  for (double& x : v) {
    if (!(in >> x)) bad_entry(file, "frame_transform", "expected 's qx qy qz qw tx ty tz'");
  }
  if (!(v[0] > 0.0)) bad_entry(file, "frame_transform", "scale must be positive");
  return Sim3(v[0], SO3::from_unit_quaternion(Eigen::Quaterniond(v[4], v[1], v[2], v[3])),
              Eigen::Vector3d(v[5], v[6], v[7]));
}

}  // namespace

std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

MetadataEntries metadata_entries(const MapMetadata& m) {
  MetadataEntries e;
  e["format"] = kFormat;
  e["coloc_version"] = m.coloc_version;
  e["saved_utc"] = m.saved_utc;
  e["vocabulary_checksum"] = hex64(m.vocabulary_checksum);
  e["vocabulary_words"] = std::to_string(m.vocabulary_words);
  e["settings"] = m.settings;
  e["frame_name"] = m.frame_name;
  e["frame_transform"] = m.frame_from_slam ? sim3_text(*m.frame_from_slam) : "";
  if (!m.registration.empty()) e["registration"] = m.registration;
  if (m.estimated_readout) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, *m.estimated_readout).ptr;
    e["estimated_readout"] = std::string(text, end);  // shortest text that reads back exactly
  }
  return e;
}

const std::string& entry(const MetadataEntries& entries, const std::string& key,
                         const std::filesystem::path& file) {
  auto it = entries.find(key);
  if (it == entries.end()) bad_entry(file, key, "missing entry");
  return it->second;
}

std::uint64_t entry_u64(const MetadataEntries& entries, const std::string& key,
                        const std::filesystem::path& file) {
  const std::string& s = entry(entries, key, file);
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || s.empty())
    bad_entry(file, key, "'" + s + "' is not an unsigned number");
  return v;
}

std::uint64_t entry_hex64(const MetadataEntries& entries, const std::string& key,
                          const std::filesystem::path& file) {
  const std::string& s = entry(entries, key, file);
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (ec != std::errc() || end != s.data() + s.size() || s.size() != 16)
    bad_entry(file, key, "'" + s + "' is not 16 hex digits");
  return v;
}

MapMetadata parse_metadata(const MetadataEntries& entries, const std::filesystem::path& file) {
  if (entry(entries, "format", file) != kFormat)
    bad_entry(file, "format", "not a coloc map (format '" + entries.at("format") + "')");
  MapMetadata m;
  m.coloc_version = entry(entries, "coloc_version", file);
  m.saved_utc = entry(entries, "saved_utc", file);
  m.vocabulary_checksum = entry_hex64(entries, "vocabulary_checksum", file);
  const std::uint64_t words = entry_u64(entries, "vocabulary_words", file);
  if (words > 0xffffffffULL) bad_entry(file, "vocabulary_words", "out of range");
  m.vocabulary_words = static_cast<std::uint32_t>(words);
  m.settings = entry(entries, "settings", file);
  m.frame_name = entry(entries, "frame_name", file);
  const std::string& transform = entry(entries, "frame_transform", file);
  if (!transform.empty()) m.frame_from_slam = parse_sim3(transform, file);
  if (const auto it = entries.find("registration"); it != entries.end())
    m.registration = it->second;
  if (const auto it = entries.find("estimated_readout"); it != entries.end()) {
    double v = -1.0;
    const std::string& s = it->second;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || !(v >= 0.0 && v < 1.0))
      bad_entry(file, "estimated_readout", "'" + s + "' is not a readout time in [0, 1) s");
    m.estimated_readout = v;
  }
  return m;
}

std::uint64_t metadata_checksum(const MetadataEntries& entries) {
  ContentHash h;
  for (const auto& [key, value] : entries) {
    if (key.rfind("checksum.", 0) == 0) continue;
    h.text(key);
    h.text(value);
  }
  return h.value();
}

}  // namespace coloc::slam::mapdb::detail
