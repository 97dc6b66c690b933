// coloc calibrate: camera intrinsics and distortion from chessboard or ChArUco photos
// (slam/capture/calibrate.hpp), written as an ORB-SLAM3 v1.0 settings file.
#include <cstdio>
#include <regex>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/capture/calibrate.hpp"
#include "slam/capture/settings_file.hpp"
#include "slam/core/error.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct CalibrateArgs {
  std::vector<fs::path> images;
  std::string chessboard, charuco, dictionary = "DICT_6X6_250";
  double square = 0.0, marker = 0.0, fps = 30.0;
  fs::path out;
  bool json = false;
};

void parse_board(const std::string& text, const char* option, capture::CalibrateOptions& o) {
  static const std::regex kSize(R"((\d+)x(\d+))");
  std::smatch m;
  if (!std::regex_match(text, m, kSize))
    throw Error("'" + text + "': expected COLSxROWS", {.field = option});
  o.cols = std::stoi(m[1]);
  o.rows = std::stoi(m[2]);
}

void run_calibrate(const CalibrateArgs& a) {
  capture::CalibrateOptions o{.square = a.square, .marker = a.marker, .dictionary = a.dictionary};
  if (a.chessboard.empty() == a.charuco.empty())
    throw CLI::ValidationError("give one of --chessboard COLSxROWS or --charuco COLSxROWS");
  if (!a.charuco.empty()) {
    o.target = capture::CalibrateOptions::Target::kCharuco;
    parse_board(a.charuco, "--charuco", o);
  } else {
    parse_board(a.chessboard, "--chessboard", o);
  }
  // An unwritable output is an error before the work.
  if (!a.out.empty() && !fs::is_directory(a.out.parent_path().empty() ? "." : a.out.parent_path()))
    throw Error("output folder does not exist", {.file = a.out.string()});
  const capture::CameraCalibration c = capture::calibrate_camera(a.images, o);
  const PinholeCamera& k = c.camera;
  if (!a.out.empty())
    capture::write_settings_file(
        a.out, {.camera = k,
                .fps = a.fps,
                .comment = "# coloc calibrate: " + std::to_string(c.used()) + " images, RMS " +
                           std::to_string(c.rms_px) + " px"});
  if (a.json) {
    Json images = Json::array();
    for (const auto& r : c.images)
      images.push_back({{"image", r.path.string()},
                        {"used", r.used},
                        {"corners", r.corners},
                        {"rms_px", r.used ? Json(r.rms_px) : Json()},
                        {"note", r.note}});
    print_json({{"width", k.width},
                {"height", k.height},
                {"fx", k.fx},
                {"fy", k.fy},
                {"cx", k.cx},
                {"cy", k.cy},
                {"distortion", k.distortion},
                {"rms_px", c.rms_px},
                {"images_used", c.used()},
                {"images", images}});
    return;
  }
  std::printf("%zu of %zu images used, RMS reprojection error %.3f px\n", c.used(), c.images.size(),
              c.rms_px);
  std::printf("fx %.3f fy %.3f cx %.3f cy %.3f  k1 %.5f k2 %.5f p1 %.5f p2 %.5f k3 %.5f (%dx%d)\n",
              k.fx, k.fy, k.cx, k.cy, k.distortion[0], k.distortion[1], k.distortion[2],
              k.distortion[3], k.distortion[4], k.width, k.height);
  for (const auto& r : c.images) {
    if (r.used)
      std::printf("  %-40s %3zu corners  %.3f px%s%s\n", r.path.filename().c_str(), r.corners,
                  r.rms_px, r.note.empty() ? "" : "  ", r.note.c_str());
    else
      std::printf("  %-40s left out: %s\n", r.path.filename().c_str(), r.note.c_str());
  }
  if (!a.out.empty()) std::printf("settings: %s\n", a.out.c_str());
}

}  // namespace

void add_calibrate_verb(CLI::App& app) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Camera intrinsics from chessboard / ChArUco photos (ORB-SLAM3 settings out)");
  // No CLI::ExistingFile: the calibrator checks each path (check_input_file), exit 1 naming it.
  cmd->add_option("images", a->images, "Photos of the board")->required();
  cmd->add_option("--chessboard", a->chessboard, "Inner corners COLSxROWS, e.g. 9x6");
  cmd->add_option("--charuco", a->charuco, "Squares COLSxROWS, e.g. 5x7");
  cmd->add_option("--square", a->square, "Square side in metres")->required();
  cmd->add_option("--marker", a->marker, "ChArUco marker side in metres");
  cmd->add_option("--dictionary", a->dictionary, "ChArUco dictionary (OpenCV name)");
  cmd->add_option("--fps", a->fps, "Camera.fps written to the settings");
  cmd->add_option("--out", a->out, "ORB-SLAM3 v1.0 settings file to write");
  cmd->add_flag("--json", a->json, "Machine-readable result");
  cmd->callback([a] { run_calibrate(*a); });
}

}  // namespace coloc::cli
