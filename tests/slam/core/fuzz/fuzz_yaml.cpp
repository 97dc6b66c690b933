// libFuzzer target over every YAML file kind coloc reads (built by scripts/fuzz_yaml with clang;
// not part of CI). COLOC_FUZZ_YAML_KIND (0-7) fixes the reader, so that each kind gets its own
// run and corpus; unset, the first byte picks it. The file is written to a tmpfs file with a
// .yaml name and read as a path would be. A coloc::Error is the expected outcome of
// bad input; a hang (libFuzzer -timeout), a crash, another exception or a sanitizer report is a
// finding. Kinds: settings, marker map, dictionary, detector parameters, capture calibration,
// replay description, session description, hand-eye calibration.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/aruco.hpp>
#include <string>

#include "fusion/session/config.hpp"
#include "markers/detector.hpp"
#include "markers/dictionary.hpp"
#include "markers/marker_map.hpp"
#include "registration/handeye/io.hpp"
#include "slam/capture/calibration.hpp"
#include "slam/capture/replay.hpp"
#include "slam/core/error.hpp"
#include "slam/settings/settings.hpp"

namespace {

namespace fs = std::filesystem;

constexpr int kKinds = 8;

// -1: the first byte of each input picks the kind.
int fixed_kind() {
  static const int kind = [] {
    const char* text = std::getenv("COLOC_FUZZ_YAML_KIND");
    return text == nullptr ? -1 : std::atoi(text) % kKinds;
  }();
  return kind;
}

const fs::path& folder() {
  static const fs::path dir = [] {
    const fs::path d = fs::path("/dev/shm") / ("coloc_fuzz_yaml_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

void read_as(int kind, const fs::path& file) {
  switch (kind) {
    case 0:
      coloc::settings::load_settings(file);
      break;
    case 1:
      coloc::markers::read_marker_map(file);
      break;
    case 2:
      coloc::markers::make_dictionary(file.string());
      break;
    case 3: {
      auto parameters = cv::aruco::DetectorParameters::create();
      coloc::markers::read_detector_parameters(file, *parameters);
      break;
    }
    case 4:
      coloc::capture::load_calibration_file(file, 640, 480);
      break;
    case 5:
      coloc::capture::load_replay(file.parent_path());
      break;
    case 6:
      coloc::fusion::session::read_session_config(file);
      break;
    default:
      coloc::registration::handeye::read_calibration(file);
      break;
  }
}

}  // namespace

// Unknown keys are logged as warnings; thousands per second would drown the fuzzer's output.
extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  spdlog::set_level(spdlog::level::off);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  int kind = fixed_kind();
  if (kind < 0) {
    if (size == 0) return 0;
    kind = data[0] % kKinds;
    ++data;
    --size;
  }
  // A replay description is DIR/replay.yaml; the others take the file itself.
  const fs::path file = folder() / (kind == 5 ? "replay.yaml" : "input.yaml");
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    read_as(kind, file);
  } catch (const coloc::Error&) {
  }
  return 0;
}
