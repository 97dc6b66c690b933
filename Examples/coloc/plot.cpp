#include "Examples/coloc/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/core/error.hpp"

namespace coloc::cli {
namespace {

constexpr int kPanelW = 640;
constexpr int kPanelH = 520;
constexpr int kMargin = 60;

std::string tick_label(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

void draw_panel(cv::Mat& canvas, int x0, const Panel& panel) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300);
  Eigen::Vector2d hi = Eigen::Vector2d::Constant(-1e300);
  for (const auto& s : panel.series) {
    for (const auto& p : s.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector2d::Zero();
  Eigen::Vector2d span = (hi - lo).cwiseMax(1e-9);
  const double plot_w = kPanelW - 2.0 * kMargin;
  const double plot_h = kPanelH - 2.0 * kMargin;
  Eigen::Vector2d scale(plot_w / span.x(), plot_h / span.y());
  if (panel.equal_aspect) scale.setConstant(scale.minCoeff());
  // Centre the data in the plot area.
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  auto to_px = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(x0 + kPanelW / 2.0 + (p.x() - centre.x()) * scale.x()),
                     static_cast<int>(kPanelH / 2.0 - (p.y() - centre.y()) * scale.y()));
  };
  const cv::Scalar grey(160, 160, 160);
  cv::rectangle(canvas, cv::Point(x0 + kMargin, kMargin),
                cv::Point(x0 + kPanelW - kMargin, kPanelH - kMargin), grey, 1);
  // Axis ticks at the data bounds, in the data's units.
  const Eigen::Vector2d view_lo(centre.x() - plot_w / 2 / scale.x(),
                                centre.y() - plot_h / 2 / scale.y());
  const Eigen::Vector2d view_hi(centre.x() + plot_w / 2 / scale.x(),
                                centre.y() + plot_h / 2 / scale.y());
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(canvas, tick_label(view_lo.x()), {x0 + kMargin, kPanelH - kMargin + 18}, font, 0.4,
              grey);
  cv::putText(canvas, tick_label(view_hi.x()),
              {x0 + kPanelW - kMargin - 30, kPanelH - kMargin + 18}, font, 0.4, grey);
  cv::putText(canvas, tick_label(view_lo.y()), {x0 + 5, kPanelH - kMargin}, font, 0.4, grey);
  cv::putText(canvas, tick_label(view_hi.y()), {x0 + 5, kMargin + 5}, font, 0.4, grey);
  cv::putText(canvas, panel.title, {x0 + kMargin, 30}, font, 0.6, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  cv::putText(canvas, panel.x_label, {x0 + kPanelW / 2 - 20, kPanelH - 20}, font, 0.45,
              cv::Scalar(0, 0, 0));
  cv::putText(canvas, panel.y_label, {x0 + 5, kMargin - 12}, font, 0.45, cv::Scalar(0, 0, 0));
  int legend_y = kMargin + 20;
  for (const auto& s : panel.series) {
    const cv::Scalar colour(s.bgr.x(), s.bgr.y(), s.bgr.z());
    for (std::size_t i = 1; i < s.points.size(); ++i) {
      cv::line(canvas, to_px(s.points[i - 1]), to_px(s.points[i]), colour, 2, cv::LINE_AA);
    }
    if (s.points.size() == 1) cv::circle(canvas, to_px(s.points[0]), 3, colour, -1);
    cv::line(canvas, {x0 + kPanelW - kMargin - 150, legend_y - 4},
             {x0 + kPanelW - kMargin - 125, legend_y - 4}, colour, 2);
    cv::putText(canvas, s.label, {x0 + kPanelW - kMargin - 118, legend_y}, font, 0.45, colour, 1,
                cv::LINE_AA);
    legend_y += 18;
  }
}

}  // namespace

void write_plot(const std::filesystem::path& path, const std::vector<Panel>& panels) {
  cv::Mat canvas(kPanelH, kPanelW * static_cast<int>(std::max<std::size_t>(1, panels.size())),
                 CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t i = 0; i < panels.size(); ++i) {
    draw_panel(canvas, static_cast<int>(i) * kPanelW, panels[i]);
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), canvas);
  } catch (const cv::Exception& e) {
    throw Error(std::string("cannot write plot: ") + e.err, {.file = path.string()});
  }
  if (!ok) throw Error("cannot write plot", {.file = path.string()});
}

}  // namespace coloc::cli
