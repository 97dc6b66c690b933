#include "e57io/paged_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "e57io/bytes.hpp"
#include "e57io/crc32c.hpp"

namespace coloc::e57 {
namespace {

constexpr char kSignature[8] = {'A', 'S', 'T', 'M', '-', 'E', '5', '7'};
constexpr std::uint64_t kWindowPages = 64;  // 64 KiB read window: bounded memory

std::uint32_t stored_crc(const std::uint8_t* page) {
  return (std::uint32_t{page[1020]} << 24) | (std::uint32_t{page[1021]} << 16) |
         (std::uint32_t{page[1022]} << 8) | std::uint32_t{page[1023]};
}

void put_crc(std::uint8_t* page) {
  const std::uint32_t c = crc32c(page, kPageData);
  page[1020] = static_cast<std::uint8_t>(c >> 24);
  page[1021] = static_cast<std::uint8_t>(c >> 16);
  page[1022] = static_cast<std::uint8_t>(c >> 8);
  page[1023] = static_cast<std::uint8_t>(c);
}

}  // namespace

void ChecksumPolicy::check() const {
  if (!(fraction >= 0.0 && fraction <= 1.0)) {
    throw Error("checksum fraction must be in [0, 1], got " + std::to_string(fraction));
  }
}

bool ChecksumPolicy::wants(std::uint64_t page) const {
  if (fraction >= 1.0) return true;
  if (fraction <= 0.0) return false;
  // splitmix64 of the page number: a fixed, well-spread choice of pages.
  std::uint64_t z = page + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53 < fraction;
}

void encode_header(const FileHeader& h, std::uint8_t out[kHeaderSize]) {
  std::memcpy(out, kSignature, 8);
  store_le<std::uint32_t>(out + 8, h.version_major);
  store_le<std::uint32_t>(out + 12, h.version_minor);
  store_le<std::uint64_t>(out + 16, h.physical_length);
  store_le<std::uint64_t>(out + 24, h.xml_physical_offset);
  store_le<std::uint64_t>(out + 32, h.xml_logical_length);
  store_le<std::uint64_t>(out + 40, h.page_size);
}

FileHeader decode_header(const std::uint8_t in[kHeaderSize], const std::string& path) {
  auto fail = [&](const std::string& msg, std::uint64_t offset) {
    return Error(msg, {.file = path, .physical_offset = offset, .page = 0});
  };
  if (std::memcmp(in, kSignature, 8) != 0)
    throw fail("not an E57 file (no 'ASTM-E57' signature)", 0);
  FileHeader h;
  h.version_major = load_le<std::uint32_t>(in + 8);
  h.version_minor = load_le<std::uint32_t>(in + 12);
  h.physical_length = load_le<std::uint64_t>(in + 16);
  h.xml_physical_offset = load_le<std::uint64_t>(in + 24);
  h.xml_logical_length = load_le<std::uint64_t>(in + 32);
  h.page_size = load_le<std::uint64_t>(in + 40);
  if (h.version_major != 1) {
    throw fail("unsupported E57 major version " + std::to_string(h.version_major), 8);
  }
  if (h.page_size != kPageSize) {
    throw fail("unsupported page size " + std::to_string(h.page_size) + " (expected 1024)", 40);
  }
  if (h.physical_length == 0 || h.physical_length % kPageSize != 0) {
    throw fail("file length " + std::to_string(h.physical_length) +
                   " in header is not a positive multiple of the page size",
               16);
  }
  return h;
}

PagedReader::PagedReader(const std::filesystem::path& path, ChecksumPolicy policy)
    : path_(path.string()), policy_(policy) {
  policy_.check();
  // Checked before open(): opening a FIFO blocks until a writer appears, and a directory or a
  // device is no E57 file either.
  struct stat info {};
  if (::stat(path_.c_str(), &info) != 0)
    throw Error(std::string("cannot open: ") + std::strerror(errno), {.file = path_});
  if (!S_ISREG(info.st_mode)) {
    throw Error(S_ISDIR(info.st_mode)    ? "is a directory, not an E57 file"
                : S_ISFIFO(info.st_mode) ? "is a FIFO (named pipe), not an E57 file"
                                         : "is not a regular file",
                {.file = path_});
  }
  fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(std::string("cannot open: ") + std::strerror(errno), {.file = path_});
  const off_t size = ::lseek(fd_, 0, SEEK_END);
  std::uint8_t raw[kHeaderSize];
  if (size < static_cast<off_t>(kHeaderSize) || ::pread(fd_, raw, kHeaderSize, 0) != kHeaderSize) {
    ::close(fd_);
    throw Error("file too short for an E57 header (" + std::to_string(size) + " bytes)",
                {.file = path_, .physical_offset = 0});
  }
  try {
    header_ = decode_header(raw, path_);
    const auto actual = static_cast<std::uint64_t>(size);
    if (actual < header_.physical_length) {
      throw Error("file is truncated: header says " + std::to_string(header_.physical_length) +
                      " bytes, file has " + std::to_string(actual),
                  {.file = path_, .physical_offset = actual});
    }
    const std::uint64_t xml_logical = physical_to_logical(header_.xml_physical_offset);
    if (header_.xml_physical_offset % kPageSize >= kPageData ||
        header_.xml_physical_offset < kHeaderSize || xml_logical > logical_length() ||
        header_.xml_logical_length > logical_length() - xml_logical) {
      throw Error("XML section (offset " + std::to_string(header_.xml_physical_offset) +
                      ", length " + std::to_string(header_.xml_logical_length) +
                      ") lies outside the file",
                  {.file = path_, .physical_offset = 24, .page = 0});
    }
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

PagedReader::~PagedReader() {
  if (fd_ >= 0) ::close(fd_);
}

Error PagedReader::error_at(const std::string& message, std::uint64_t logical,
                            const std::string& element) const {
  return Error(message, {.file = path_,
                         .physical_offset = logical_to_physical(logical),
                         .logical_offset = logical,
                         .page = logical / kPageData,
                         .element = element});
}

void PagedReader::check_page(std::uint64_t page, const std::uint8_t* bytes) const {
  const std::uint32_t want = stored_crc(bytes);
  const std::uint32_t got = crc32c(bytes, kPageData);
  if (want != got) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "page checksum mismatch (stored 0x%08X, computed 0x%08X)", want,
                  got);
    throw Error(buf, {.file = path_,
                      .physical_offset = page * kPageSize,
                      .logical_offset = page * kPageData,
                      .page = page});
  }
}

void PagedReader::load_window(std::uint64_t first_page) {
  const std::uint64_t pages = std::min(kWindowPages, page_count() - first_page);
  window_.resize(pages * kPageSize);
  std::size_t done = 0;
  while (done < window_.size()) {
    const ssize_t n = ::pread(fd_, window_.data() + done, window_.size() - done,
                              static_cast<off_t>(first_page * kPageSize + done));
    if (n <= 0) {
      window_pages_ = 0;
      throw Error("read failed", {.file = path_, .physical_offset = first_page * kPageSize + done});
    }
    done += static_cast<std::size_t>(n);
  }
  window_first_ = first_page;
  window_pages_ = pages;
  // CRCs of the wanted pages are computed now, three pages at a time (independent chains), but a
  // mismatch is reported only when a page is read from, so an error names a page the caller
  // needed. window_checked_: 1 = fine or not wanted, 0 = mismatch (check_page() throws).
  window_checked_.assign(pages, 1);
  std::uint64_t wanted[kWindowPages];
  std::size_t count = 0;
  for (std::uint64_t i = 0; i < pages; ++i) {
    if (policy_.wants(first_page + i)) wanted[count++] = i;
  }
  const std::uint8_t* base = window_.data();
  std::size_t k = 0;
  for (; k + 3 <= count; k += 3) {
    std::uint32_t crc[3];
    crc32c_x3(base + wanted[k] * kPageSize, base + wanted[k + 1] * kPageSize,
              base + wanted[k + 2] * kPageSize, kPageData, crc);
    for (std::size_t j = 0; j < 3; ++j) {
      window_checked_[wanted[k + j]] = crc[j] == stored_crc(base + wanted[k + j] * kPageSize);
    }
  }
  for (; k < count; ++k) {
    const std::uint8_t* page = base + wanted[k] * kPageSize;
    window_checked_[wanted[k]] = crc32c(page, kPageData) == stored_crc(page);
  }
}

void PagedReader::read(std::uint64_t logical, std::span<std::uint8_t> out) {
  std::size_t done = 0;
  while (done < out.size()) {
    const std::uint64_t pos = logical + done;
    const std::uint64_t page = pos / kPageData;
    if (page >= page_count()) {
      throw error_at(
          "read of " + std::to_string(out.size()) + " bytes runs past the end of the file",
          logical);
    }
    if (page < window_first_ || page >= window_first_ + window_pages_) load_window(page);
    const std::uint64_t slot = page - window_first_;
    if (window_checked_[slot] == 0) check_page(page, window_.data() + slot * kPageSize);
    const std::uint64_t in_page = pos % kPageData;
    const std::size_t n =
        static_cast<std::size_t>(std::min<std::uint64_t>(kPageData - in_page, out.size() - done));
    std::memcpy(out.data() + done, window_.data() + slot * kPageSize + in_page, n);
    done += n;
  }
}

void PagedReader::verify_all_pages() {
  std::vector<std::uint8_t> buf(kWindowPages * kPageSize);
  for (std::uint64_t first = 0; first < page_count(); first += kWindowPages) {
    const std::uint64_t pages = std::min(kWindowPages, page_count() - first);
    const auto bytes = static_cast<std::size_t>(pages * kPageSize);
    if (::pread(fd_, buf.data(), bytes, static_cast<off_t>(first * kPageSize)) !=
        static_cast<ssize_t>(bytes)) {
      throw Error("read failed", {.file = path_, .physical_offset = first * kPageSize});
    }
    for (std::uint64_t i = 0; i < pages; ++i)
      check_page(first + i, buf.data() + i * kPageSize);
  }
}

// ---------------------------------------------------------------------------------------------

PagedWriter::PagedWriter(const std::filesystem::path& path)
    : path_(path.string()), page_(kPageSize, 0) {
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw Error(std::string("cannot create: ") + std::strerror(errno), {.file = path_});
  }
  write_zeros(kHeaderSize);  // the header is filled in by finish()
}

PagedWriter::~PagedWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void PagedWriter::write_physical(std::uint64_t offset, const std::uint8_t* data, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::pwrite(fd_, data + done, size - done, static_cast<off_t>(offset + done));
    if (n <= 0) {
      throw Error(std::string("write failed: ") + std::strerror(errno),
                  {.file = path_, .physical_offset = offset + done});
    }
    done += static_cast<std::size_t>(n);
  }
}

void PagedWriter::read_physical(std::uint64_t offset, std::uint8_t* data, std::size_t size) {
  if (::pread(fd_, data, size, static_cast<off_t>(offset)) != static_cast<ssize_t>(size)) {
    throw Error("read back failed", {.file = path_, .physical_offset = offset});
  }
}

void PagedWriter::flush_page() {
  put_crc(page_.data());
  const std::uint64_t page = (position_ - 1) / kPageData;
  write_physical(page * kPageSize, page_.data(), kPageSize);
  std::fill(page_.begin(), page_.end(), 0);
}

void PagedWriter::write(std::span<const std::uint8_t> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const std::uint64_t in_page = position_ % kPageData;
    const std::size_t n =
        static_cast<std::size_t>(std::min<std::uint64_t>(kPageData - in_page, bytes.size() - done));
    std::memcpy(page_.data() + in_page, bytes.data() + done, n);
    position_ += n;
    done += n;
    if (position_ % kPageData == 0) flush_page();
  }
}

void PagedWriter::write_zeros(std::uint64_t count) {
  static constexpr std::uint8_t kZeros[256] = {};
  while (count > 0) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(count, sizeof kZeros));
    write({kZeros, n});
    count -= n;
  }
}

void PagedWriter::align(std::uint64_t multiple) {
  const std::uint64_t rem = position_ % multiple;
  if (rem != 0) write_zeros(multiple - rem);
}

void PagedWriter::patch(std::uint64_t logical, std::span<const std::uint8_t> bytes) {
  const std::uint64_t open_page = position_ / kPageData;  // the page still in page_
  std::size_t done = 0;
  std::vector<std::uint8_t> page(kPageSize);
  while (done < bytes.size()) {
    const std::uint64_t pos = logical + done;
    const std::uint64_t p = pos / kPageData;
    const std::uint64_t in_page = pos % kPageData;
    const std::size_t n =
        static_cast<std::size_t>(std::min<std::uint64_t>(kPageData - in_page, bytes.size() - done));
    if (p == open_page) {
      std::memcpy(page_.data() + in_page, bytes.data() + done, n);
    } else {
      read_physical(p * kPageSize, page.data(), kPageSize);
      std::memcpy(page.data() + in_page, bytes.data() + done, n);
      put_crc(page.data());
      write_physical(p * kPageSize, page.data(), kPageSize);
    }
    done += n;
  }
}

std::uint64_t PagedWriter::finish(FileHeader header) {
  if (position_ % kPageData != 0) {
    // Pad the last page with zeros (its CRC covers them).
    write_zeros(kPageData - position_ % kPageData);
  }
  header.physical_length = (position_ / kPageData) * kPageSize;
  std::uint8_t raw[kHeaderSize];
  encode_header(header, raw);
  patch(0, raw);
  if (::close(fd_) != 0) {
    fd_ = -1;
    throw Error(std::string("close failed: ") + std::strerror(errno), {.file = path_});
  }
  fd_ = -1;
  return header.physical_length;
}

}  // namespace coloc::e57
