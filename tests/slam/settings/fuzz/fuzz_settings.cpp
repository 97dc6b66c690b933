// libFuzzer target for the settings parser (built by scripts/fuzz_settings with clang; not part
// of CI). The input is written to an in-memory file and loaded as a settings path would be:
// OpenCV's YAML reader, then every key check of load_settings. A coloc::Error is the expected
// outcome of bad input; any other exception, crash, hang or sanitizer report is a finding, and
// so is a "successful" load with values no camera has.

#include <spdlog/spdlog.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "slam/core/error.hpp"
#include "slam/settings/settings.hpp"

namespace {

void check_plausible(const coloc::settings::Settings& s) {
  const auto& o = s.orb;
  if (o.n_features < 1 || o.n_features > 100000 || !(o.scale_factor > 1.0) || o.n_levels < 1 ||
      o.n_levels > 32 || !std::isfinite(s.fps) || !(s.fps > 0.0)) {
    std::abort();
  }
  if (s.depth && !(s.depth->depth_map_factor > 0.0 && std::isfinite(s.depth->bf))) std::abort();
}

}  // namespace

// Unknown keys are logged as warnings; thousands per second would drown the fuzzer's output.
extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  spdlog::set_level(spdlog::level::off);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const int fd = memfd_create("settings", 0);
  if (fd < 0) return 0;
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  try {
    check_plausible(coloc::settings::load_settings("/proc/self/fd/" + std::to_string(fd)));
  } catch (const coloc::Error&) {
  }
  close(fd);
  return 0;
}
