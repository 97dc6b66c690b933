// libFuzzer target for the E57 reader (built by scripts/fuzz_e57 with clang; not part of CI).
// The input is written to an in-memory file and read like a real one: XML, every scan's points
// (streamed, capped), line groups, images. Page CRCs are not checked (ChecksumPolicy::none) so
// mutations reach the structure behind them; verify_all_pages() still runs the CRC code. Any
// exception other than coloc::e57::Error, any crash or sanitizer report is a finding.

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "e57io/crc32c.hpp"
#include "e57io/paged_file.hpp"
#include "e57io/reader.hpp"

namespace {

void exercise(const std::string& path, coloc::e57::ChecksumPolicy policy) {
  using namespace coloc::e57;
  try {
    PagedReader(path, ChecksumPolicy::none()).verify_all_pages();
  } catch (const Error&) {
  }
  const Reader reader(path, {.checksums = policy});
  for (std::size_t s = 0; s < reader.scans().size(); ++s) {
    try {
      PointStream stream = reader.open_points(s);
      PointBuffer chunk;
      std::uint64_t total = 0;
      while (total < 200000 && stream.read(chunk, 4096) > 0)
        total += chunk.size;
    } catch (const Error&) {
    }
    try {
      if (reader.scans()[s].point_count < 100000) reader.read_points(s);
    } catch (const Error&) {
    }
    try {
      reader.read_line_groups(s);
    } catch (const Error&) {
    }
  }
  for (std::size_t i = 0; i < reader.images().size(); ++i) {
    try {
      reader.read_image(i);
      reader.read_image_mask(i);
    } catch (const Error&) {
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Half of the inputs get correct page CRCs and are read with every CRC checked, so the
  // checked read path (three pages per CRC pass) is fuzzed too.
  std::vector<std::uint8_t> bytes(data, data + size);
  const bool fix_crcs = size >= 1024 && ((data[0] ^ data[size - 1]) & 1u) != 0;
  if (fix_crcs) {
    for (std::size_t page = 0; (page + 1) * 1024 <= size; ++page) {
      std::uint8_t* p = bytes.data() + page * 1024;
      const std::uint32_t c = coloc::e57::crc32c(p, 1020);
      p[1020] = static_cast<std::uint8_t>(c >> 24);
      p[1021] = static_cast<std::uint8_t>(c >> 16);
      p[1022] = static_cast<std::uint8_t>(c >> 8);
      p[1023] = static_cast<std::uint8_t>(c);
    }
  }
  const int fd = memfd_create("e57fuzz", 0);
  if (fd < 0) return 0;
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, bytes.data() + done, size - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  try {
    exercise("/proc/self/fd/" + std::to_string(fd),
             fix_crcs ? coloc::e57::ChecksumPolicy::all() : coloc::e57::ChecksumPolicy::none());
  } catch (const coloc::e57::Error&) {
  }
  close(fd);
  return 0;
}
