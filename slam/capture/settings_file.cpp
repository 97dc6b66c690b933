#include "slam/capture/settings_file.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "slam/core/error.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;

void write_file_atomically(const fs::path& path, const std::string& text) {
  const fs::path temp = path.string() + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary);
    out << text;
    out.flush();
    if (!out) throw Error("cannot write", {.file = temp.string()});
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) throw Error("cannot rename into place: " + ec.message(), {.file = path.string()});
}

void write_settings_file(const fs::path& path, const SettingsFileContent& c) {
  auto num = [](double v) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.9g", v);
    std::string s = buf;
    // OpenCV's YAML reads "600" as an int; ORB-SLAM3 wants these keys as reals.
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";
    return s;
  };
  const PinholeCamera& k = c.camera;
  std::ostringstream o;
  o << "%YAML:1.0\n"
    << c.comment << "\nFile.version: \"1.0\"\n\nCamera.type: \"PinHole\"\n\n"
    << "Camera1.fx: " << num(k.fx) << "\nCamera1.fy: " << num(k.fy) << "\nCamera1.cx: " << num(k.cx)
    << "\nCamera1.cy: " << num(k.cy) << "\n\nCamera1.k1: " << num(k.distortion[0])
    << "\nCamera1.k2: " << num(k.distortion[1]) << "\nCamera1.p1: " << num(k.distortion[2])
    << "\nCamera1.p2: " << num(k.distortion[3]) << "\nCamera1.k3: " << num(k.distortion[4])
    << "\n\nCamera.width: " << k.width << "\nCamera.height: " << k.height
    << "\n\nCamera.fps: " << std::lround(c.fps) << "\nCamera.RGB: " << (c.rgb ? 1 : 0) << "\n"
    << "\n# coloc: the D455's colour camera has a global shutter (no readout to estimate).\n"
    << "Camera.readoutTime: 0\n";
  if (c.depth_map_factor > 0)
    o << "\nStereo.ThDepth: 40.0\nStereo.b: " << num(c.baseline_m > 0 ? c.baseline_m : 0.05)
      << "\nRGBD.DepthMapFactor: " << num(c.depth_map_factor) << "\n";
  o << "\nORBextractor.nFeatures: 1000\nORBextractor.scaleFactor: 1.2\nORBextractor.nLevels: 8\n"
    << "ORBextractor.iniThFAST: 20\nORBextractor.minThFAST: 7\n";
  write_file_atomically(path, o.str());
}

}  // namespace coloc::capture
