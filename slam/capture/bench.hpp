#pragma once
// Speed figures of the capture path (`coloc bench capture`), measured here so that the tests
// and the CLI reach them alike: decode + registration per depth/colour pair (thread CPU time,
// one core), and the recorder's sustained write rate (PNG encoding on its workers).
#include <filesystem>

#include "slam/capture/calibration.hpp"
#include "slam/core/timing.hpp"

namespace coloc::capture {

struct DecodeBench {
  int depth_width = 848, depth_height = 480, color_width = 640, color_height = 480;
  SampleStats z16_ms, yuyv_ms, register_ms, total_ms;  // per pair, thread CPU time
};

// `pairs` synthetic D455 pairs (sloped walls with holes, textured colour) through decode_z16,
// decode_color (YUYV) and DepthRegistrar with the nominal D455 calibration.
DecodeBench measure_decode_register(int pairs, int depth_width = 848, int depth_height = 480,
                                    int color_width = 640, int color_height = 480);

struct WriteBench {
  std::size_t frames = 0;
  double seconds = 0.0;  // wall time from the first add() to close() returning
  double frames_per_second = 0.0;
  double megabytes_per_second = 0.0;  // PNG bytes written
  unsigned workers = 0;
};

// Records `frames` synthetic 640x480 pairs into `dir` (which must not hold a recording) as
// fast as the Recorder takes them.
WriteBench measure_recorder(const std::filesystem::path& dir, std::size_t frames, unsigned workers);

}  // namespace coloc::capture
