#pragma once
// The E57 file layer (ASTM E2807 section 7): a 48-byte header, then 1024-byte pages, each 1020
// data bytes followed by the CRC-32C of those bytes stored big-endian. "Logical" offsets count
// data bytes only; "physical" offsets count the bytes as stored. Binary sections and the XML are
// addressed by physical offsets but read as logical byte runs that skip the CRCs.
//
// PagedReader and PagedWriter own one file descriptor each; neither is thread-safe, but
// independent instances on the same file are (each point stream opens its own reader).

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "e57io/error.hpp"

namespace coloc::e57 {

inline constexpr std::uint64_t kPageSize = 1024;
inline constexpr std::uint64_t kPageData = 1020;
inline constexpr std::uint64_t kHeaderSize = 48;

inline constexpr std::uint64_t physical_to_logical(std::uint64_t physical) {
  return (physical / kPageSize) * kPageData + physical % kPageSize;
}
inline constexpr std::uint64_t logical_to_physical(std::uint64_t logical) {
  return (logical / kPageData) * kPageSize + logical % kPageData;
}

struct FileHeader {
  std::uint32_t version_major = 1;
  std::uint32_t version_minor = 0;
  std::uint64_t physical_length = 0;  // whole file, a multiple of page_size
  std::uint64_t xml_physical_offset = 0;
  std::uint64_t xml_logical_length = 0;
  std::uint64_t page_size = kPageSize;
};

// Which pages have their CRC checked when read. fraction 1 = all (default), 0 = none; in
// between, a deterministic pseudo-random subset of that share of pages (same pages every run).
struct ChecksumPolicy {
  double fraction = 1.0;
  static ChecksumPolicy all() { return {1.0}; }
  static ChecksumPolicy none() { return {0.0}; }
  static ChecksumPolicy sampled(double f) { return {f}; }
  void check() const;  // throws Error naming "checksum fraction" unless 0 <= fraction <= 1
  bool wants(std::uint64_t page) const;
};

class PagedReader {
 public:
  // Opens and validates the header (signature, version, page size, lengths). Throws Error.
  PagedReader(const std::filesystem::path& path, ChecksumPolicy policy = {});
  ~PagedReader();
  PagedReader(const PagedReader&) = delete;
  PagedReader& operator=(const PagedReader&) = delete;

  const FileHeader& header() const { return header_; }
  const std::string& path() const { return path_; }
  std::uint64_t page_count() const { return header_.physical_length / kPageSize; }
  std::uint64_t logical_length() const { return page_count() * kPageData; }

  // Copies out.size() logical bytes starting at `logical`. Throws Error (with page and offsets)
  // on a CRC mismatch or a read past the end of the file.
  void read(std::uint64_t logical, std::span<std::uint8_t> out);

  // Checks every page's CRC regardless of the policy; throws on the first mismatch.
  void verify_all_pages();

  // An Error carrying this file's path and the offsets of `logical`.
  Error error_at(const std::string& message, std::uint64_t logical,
                 const std::string& element = {}) const;

 private:
  void load_window(std::uint64_t first_page);
  void check_page(std::uint64_t page, const std::uint8_t* bytes) const;

  std::string path_;
  int fd_ = -1;
  ChecksumPolicy policy_;
  FileHeader header_;
  std::vector<std::uint8_t> window_;  // whole physical pages [window_first_, +window_pages_)
  std::uint64_t window_first_ = 0;
  std::uint64_t window_pages_ = 0;
  std::vector<std::uint8_t> window_checked_;  // per window page: 1 = CRC fine or not wanted
};

// Writes a paged file sequentially in logical bytes; computes page CRCs as pages fill. Bytes
// already written can be patched (section headers whose lengths are known only at the end).
class PagedWriter {
 public:
  explicit PagedWriter(const std::filesystem::path& path);  // truncates; throws Error
  ~PagedWriter();
  PagedWriter(const PagedWriter&) = delete;
  PagedWriter& operator=(const PagedWriter&) = delete;

  std::uint64_t logical_position() const { return position_; }
  std::uint64_t physical_position() const { return logical_to_physical(position_); }

  void write(std::span<const std::uint8_t> bytes);
  void write_zeros(std::uint64_t count);
  void align(std::uint64_t multiple);  // pads with zeros to a multiple of `multiple` bytes
  // Overwrites bytes at `logical` (< logical_position()).
  void patch(std::uint64_t logical, std::span<const std::uint8_t> bytes);
  // Pads the last page, writes the header into page 0 and closes. Returns the file length.
  std::uint64_t finish(FileHeader header);

 private:
  void flush_page();
  void write_physical(std::uint64_t offset, const std::uint8_t* data, std::size_t size);
  void read_physical(std::uint64_t offset, std::uint8_t* data, std::size_t size);

  std::string path_;
  int fd_ = -1;
  std::uint64_t position_ = 0;      // logical
  std::vector<std::uint8_t> page_;  // kPageSize bytes: the page being filled
};

// Encodes/decodes the 48-byte header (little-endian).
void encode_header(const FileHeader& header, std::uint8_t out[kHeaderSize]);
FileHeader decode_header(const std::uint8_t in[kHeaderSize], const std::string& path);

}  // namespace coloc::e57
