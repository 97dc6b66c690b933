#include "Examples/coloc/scan_figures.hpp"

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"

namespace coloc::cli {

namespace fs = std::filesystem;

std::optional<cv::Mat> sequence_image(const fs::path& sequence, double timestamp,
                                      const Camera& camera, const PinholeCamera& ideal) {
  std::ifstream list(sequence / "rgb.txt");
  if (!list) throw Error("cannot read the image list", {.file = (sequence / "rgb.txt").string()});
  std::string line;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t = 0.0;
    std::string name;
    if (!(s >> t >> name) || std::abs(t - timestamp) > 1e-3) continue;
    const cv::Mat raw = cv::imread((sequence / name).string(), cv::IMREAD_COLOR);
    if (raw.empty()) throw Error("cannot read the image", {.file = (sequence / name).string()});
    const auto* pin = std::get_if<PinholeCamera>(&camera);
    if (!pin || !pin->has_distortion()) return raw;
    const cv::Matx33d k(pin->fx, 0, pin->cx, 0, pin->fy, pin->cy, 0, 0, 1);
    const cv::Matx33d kn(ideal.fx, 0, ideal.cx, 0, ideal.fy, ideal.cy, 0, 0, 1);
    const std::vector<double> d(pin->distortion.begin(), pin->distortion.end());
    cv::Mat out;
    cv::undistort(raw, out, k, d, kn);
    return out;
  }
  return std::nullopt;
}

cv::Mat scan_figure(const cv::Mat& rendering_rgb, const cv::Mat& image_bgr,
                    const std::vector<registration::align::ScanCorrespondence>& matches,
                    const std::string& caption) {
  cv::Mat out;
  cv::cvtColor(rendering_rgb, out, cv::COLOR_RGB2BGR);
  if (!image_bgr.empty() && image_bgr.size() == out.size())
    cv::addWeighted(out, 0.5, image_bgr, 0.5, 0.0, out);
  for (const auto& m : matches) {
    const cv::Point2d a(m.image_px.x(), m.image_px.y()), b(m.render_px.x(), m.render_px.y());
    const cv::Scalar colour = m.inlier ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 0, 230);
    cv::line(out, a, b, colour, 1, cv::LINE_AA);
    cv::circle(out, a, 2, colour, cv::FILLED, cv::LINE_AA);
  }
  cv::putText(out, caption, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  cv::putText(out, caption, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return out;
}

void write_png(const fs::path& path, const cv::Mat& image) {
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", image, png))
    throw Error("cannot encode the PNG", {.file = path.string()});
  write_file_atomically(path,
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace coloc::cli
