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

#include "e57io/paged_file.hpp"
#include "e57io/reader.hpp"

namespace {

void exercise(const std::string& path) {
  using namespace coloc::e57;
  try {
    PagedReader(path, ChecksumPolicy::none()).verify_all_pages();
  } catch (const Error&) {
  }
  const Reader reader(path, {.checksums = ChecksumPolicy::none()});
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
  const int fd = memfd_create("e57fuzz", 0);
  if (fd < 0) return 0;
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  try {
    exercise("/proc/self/fd/" + std::to_string(fd));
  } catch (const coloc::e57::Error&) {
  }
  close(fd);
  return 0;
}
