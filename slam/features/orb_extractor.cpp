#include "slam/features/orb_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <variant>

#include "slam/core/error.hpp"
#include "slam/features/quadtree.hpp"

namespace coloc::slam::features {
namespace {

// FAST is first tried at ini_th_fast within cells of about this size (pixels, per level).
constexpr float kCellSize = 30.0f;

[[noreturn]] void bad_option(const std::string& field, const std::string& why) {
  throw Error("invalid ORB extractor option: " + why, {.field = field});
}

}  // namespace

void ExtractorOptions::check() const {
  if (n_features < 1) bad_option("n_features", "must be at least 1");
  if (!(scale_factor > 1.0) || !(scale_factor < 4.0)) {
    bad_option("scale_factor", "must be in (1, 4)");
  }
  if (n_levels < 1 || n_levels > 32) bad_option("n_levels", "must be in [1, 32]");
  if (ini_th_fast < 1 || ini_th_fast > 255) bad_option("ini_th_fast", "must be in [1, 255]");
  if (min_th_fast < 1 || min_th_fast > ini_th_fast) {
    bad_option("min_th_fast", "must be in [1, ini_th_fast]");
  }
}

OrbExtractor::OrbExtractor(ExtractorOptions options) : options_(options) {
  options_.check();
  const auto n = static_cast<std::size_t>(options_.n_levels);
  scales_.resize(n);
  sigma2_.resize(n);
  double scale = 1.0;
  for (std::size_t l = 0; l < n; ++l) {
    scales_[l] = static_cast<float>(scale);
    sigma2_[l] = static_cast<float>(scale * scale);
    scale *= options_.scale_factor;
  }
  // Quotas fall geometrically with the level area's square root (ORB-SLAM's split); the last
  // level takes what rounding left.
  quota_.resize(n);
  const double factor = 1.0 / options_.scale_factor;
  double desired = options_.n_features * (1.0 - factor) /
                   (1.0 - std::pow(factor, static_cast<double>(options_.n_levels)));
  int assigned = 0;
  for (std::size_t l = 0; l + 1 < n; ++l) {
    quota_[l] = static_cast<int>(std::lround(desired));
    assigned += quota_[l];
    desired *= factor;
  }
  quota_[n - 1] = std::max(options_.n_features - assigned, 0);

  // Half-width of the orientation disc at each row offset: the disc u^2 + v^2 <= R^2 + R, which
  // is symmetric in u and v so that rotating the image by 90 degrees rotates the disc onto itself.
  const int r = kOrientationRadius;
  umax_.resize(r + 1);
  for (int v = 0; v <= r; ++v) {
    umax_[static_cast<std::size_t>(v)] = static_cast<int>(std::floor(std::sqrt(r * r + r - v * v)));
  }
  levels_.resize(n);
  smoothed_.resize(n);
}

void OrbExtractor::build_pyramid(const cv::Mat& grey) {
  levels_[0] = grey;
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    const cv::Size size(static_cast<int>(std::lround(grey.cols / scales_[l])),
                        static_cast<int>(std::lround(grey.rows / scales_[l])));
    if (size.width < 1 || size.height < 1) {
      levels_[l].release();
      continue;
    }
    cv::resize(levels_[l - 1], levels_[l], size, 0, 0, cv::INTER_LINEAR);
  }
}

namespace {

// Cells split [lo, hi) at the integer edges lo + (i * (hi - lo)) / n, i = 0..n.
int cell_edge(int i, int lo, int hi, int n) {
  return lo + (i * (hi - lo)) / n;
}

// The cell holding integer v: the exact inverse of cell_edge (the first guess can be one off).
int cell_of(int v, int lo, int hi, int n) {
  int c = std::min(n - 1, ((v - lo) * n) / (hi - lo));
  while (c + 1 < n && v >= cell_edge(c + 1, lo, hi, n)) {
    ++c;
  }
  while (c > 0 && v < cell_edge(c, lo, hi, n)) {
    --c;
  }
  return c;
}

float intensity_centroid_angle(const cv::Mat& image, int x, int y, const std::vector<int>& umax) {
  const int r = OrbExtractor::kOrientationRadius;
  const auto step = static_cast<std::ptrdiff_t>(image.step1());
  const std::uint8_t* center = image.ptr<std::uint8_t>(y) + x;
  int m10 = 0;
  int m01 = 0;
  for (int u = -r; u <= r; ++u)
    m10 += u * center[u];
  for (int v = 1; v <= r; ++v) {
    const int d = umax[static_cast<std::size_t>(v)];
    const std::uint8_t* below = center + v * step;
    const std::uint8_t* above = center - v * step;
    int v_sum = 0;
    for (int u = -d; u <= d; ++u) {
      const int b = below[u];
      const int a = above[u];
      v_sum += b - a;
      m10 += u * (b + a);
    }
    m01 += v * v_sum;
  }
  float angle = std::atan2(static_cast<float>(m01), static_cast<float>(m10));
  if (angle < 0.0f) angle += static_cast<float>(2.0 * std::numbers::pi);
  return angle;
}

}  // namespace

void OrbExtractor::detect_level(int level, std::vector<Keypoint>& out) {
  const cv::Mat& image = levels_[static_cast<std::size_t>(level)];
  const int quota = quota_[static_cast<std::size_t>(level)];
  if (image.empty() || quota == 0) return;
  const int min_x = kBorder;
  const int min_y = kBorder;
  const int max_x = image.cols - kBorder;
  const int max_y = image.rows - kBorder;
  if (max_x - min_x < 8 || max_y - min_y < 8) return;

  // FAST at ini_th_fast over the whole level, then at min_th_fast only inside the cells (about
  // kCellSize wide) where the first pass found nothing: ORB-SLAM's fallback, which gives
  // low-contrast regions features too. A cell is searched with 3 px of context around it (the
  // radius of the FAST circle) and keeps only corners inside it, so cells never share a corner.
  const float width = static_cast<float>(max_x - min_x);
  const float height = static_cast<float>(max_y - min_y);
  const int cols = std::max(1, static_cast<int>(std::lround(width / kCellSize)));
  const int rows = std::max(1, static_cast<int>(std::lround(height / kCellSize)));
  auto cell_edge_x = [&](int c) { return cell_edge(c, min_x, max_x, cols); };
  auto cell_edge_y = [&](int r) { return cell_edge(r, min_y, max_y, rows); };

  std::vector<cv::KeyPoint> corners;
  const cv::Rect roi(min_x - 3, min_y - 3, max_x - min_x + 6, max_y - min_y + 6);
  cv::FAST(image(roi), corners, options_.ini_th_fast, true, cv::FastFeatureDetector::TYPE_9_16);
  std::vector<Candidate> candidates;
  candidates.reserve(corners.size() + 256);
  std::vector<char> occupied(static_cast<std::size_t>(cols * rows), 0);
  for (const cv::KeyPoint& k : corners) {
    const int x = static_cast<int>(k.pt.x) + roi.x;
    const int y = static_cast<int>(k.pt.y) + roi.y;
    candidates.push_back({static_cast<float>(x), static_cast<float>(y), k.response});
    const int c = cell_of(x, min_x, max_x, cols);
    const int r = cell_of(y, min_y, max_y, rows);
    occupied[static_cast<std::size_t>(r * cols + c)] = 1;
  }
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (occupied[static_cast<std::size_t>(r * cols + c)] != 0) continue;
      const cv::Rect cell(cell_edge_x(c), cell_edge_y(r), cell_edge_x(c + 1) - cell_edge_x(c),
                          cell_edge_y(r + 1) - cell_edge_y(r));
      const cv::Rect search(cell.x - 3, cell.y - 3, cell.width + 6, cell.height + 6);
      cv::FAST(image(search), corners, options_.min_th_fast, true,
               cv::FastFeatureDetector::TYPE_9_16);
      for (const cv::KeyPoint& k : corners) {
        const int x = static_cast<int>(k.pt.x) + search.x;
        const int y = static_cast<int>(k.pt.y) + search.y;
        if (cell.contains(cv::Point(x, y))) {
          candidates.push_back({static_cast<float>(x), static_cast<float>(y), k.response});
        }
      }
    }
  }

  const std::vector<int> selected =
      distribute_quadtree(candidates, quota, static_cast<float>(min_x), static_cast<float>(max_x),
                          static_cast<float>(min_y), static_cast<float>(max_y));
  for (int idx : selected) {
    const Candidate& c = candidates[static_cast<std::size_t>(idx)];
    Keypoint kp;
    kp.x = c.x;  // level coordinates until extract() scales them
    kp.y = c.y;
    kp.response = c.response;
    kp.level = level;
    kp.angle = intensity_centroid_angle(image, static_cast<int>(c.x), static_cast<int>(c.y), umax_);
    out.push_back(kp);
  }
}

void OrbExtractor::describe_level(int level, const std::vector<Keypoint>& keypoints,
                                  std::size_t first, std::vector<Descriptor>& out) {
  cv::Mat& smoothed = smoothed_[static_cast<std::size_t>(level)];
  // Smoothing makes the pixel comparisons of BRIEF robust to noise (Calonder et al.).
  cv::GaussianBlur(levels_[static_cast<std::size_t>(level)], smoothed, cv::Size(7, 7), 2.0, 2.0,
                   cv::BORDER_REFLECT_101);
  const auto step = static_cast<std::ptrdiff_t>(smoothed.step1());
  for (std::size_t i = first; i < keypoints.size(); ++i) {
    const Keypoint& kp = keypoints[i];
    const std::uint8_t* center =
        smoothed.ptr<std::uint8_t>(static_cast<int>(kp.y)) + static_cast<int>(kp.x);
    const BriefPattern::Offset* offsets = pattern_.rotated(BriefPattern::angle_bin(kp.angle));
    Descriptor d{};
    for (int w = 0; w < 4; ++w) {
      std::uint64_t bits = 0;
      for (int j = 0; j < 64; ++j) {
        const BriefPattern::Offset& p = offsets[2 * (w * 64 + j)];
        const BriefPattern::Offset& q = offsets[2 * (w * 64 + j) + 1];
        const bool less = center[p.dy * step + p.dx] < center[q.dy * step + q.dx];
        bits |= static_cast<std::uint64_t>(less) << j;
      }
      d[static_cast<std::size_t>(w)] = bits;
    }
    out.push_back(d);
  }
}

OrbFeatures OrbExtractor::extract(const cv::Mat& image, const Camera* camera) {
  if (image.empty()) throw Error("ORB extraction: empty image", {.field = "image"});
  cv::Mat grey;
  if (image.type() == CV_8UC1) {
    grey = image;
  } else if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else {
    throw Error("ORB extraction: image must be 8-bit grey or BGR (got OpenCV type " +
                    std::to_string(image.type()) + ")",
                {.field = "image"});
  }
  build_pyramid(grey);

  OrbFeatures features;
  features.image_width = grey.cols;
  features.image_height = grey.rows;
  features.keypoints.reserve(static_cast<std::size_t>(options_.n_features));
  features.descriptors.reserve(static_cast<std::size_t>(options_.n_features));
  for (int level = 0; level < options_.n_levels; ++level) {
    const std::size_t first = features.keypoints.size();
    detect_level(level, features.keypoints);
    if (features.keypoints.size() == first) continue;
    describe_level(level, features.keypoints, first, features.descriptors);
    // Pixel centres, not corners, line up between levels (cv::resize maps x_dst to
    // (x_dst + 0.5) * ratio - 0.5, and such maps compose): plain x * scale would shift level-k
    // keypoints by 0.5 * (scale - 1) px, 1.3 px at level 7, a bias bundle adjustment then
    // spreads over the map.
    const cv::Mat& img = levels_[static_cast<std::size_t>(level)];
    const float sx = static_cast<float>(grey.cols) / static_cast<float>(img.cols);
    const float sy = static_cast<float>(grey.rows) / static_cast<float>(img.rows);
    for (std::size_t i = first; i < features.keypoints.size(); ++i) {
      features.keypoints[i].x = (features.keypoints[i].x + 0.5f) * sx - 0.5f;
      features.keypoints[i].y = (features.keypoints[i].y + 0.5f) * sy - 0.5f;
    }
  }

  const bool distorted = camera != nullptr && (!std::holds_alternative<PinholeCamera>(*camera) ||
                                               std::get<PinholeCamera>(*camera).has_distortion());
  for (Keypoint& kp : features.keypoints) {
    kp.ux = kp.x;
    kp.uy = kp.y;
    if (!distorted) continue;
    const Eigen::Vector2d u = undistort_pixel(*camera, Eigen::Vector2d(kp.x, kp.y));
    kp.ux = static_cast<float>(u.x());
    kp.uy = static_cast<float>(u.y());
  }
  return features;
}

double grid_coverage(const std::vector<Keypoint>& keypoints, int image_width, int image_height,
                     int cols, int rows) {
  if (image_width <= 0 || image_height <= 0 || cols <= 0 || rows <= 0) return 0.0;
  std::vector<char> hit(static_cast<std::size_t>(cols * rows), 0);
  for (const Keypoint& kp : keypoints) {
    const int c =
        std::clamp(static_cast<int>(kp.x * static_cast<float>(cols) / image_width), 0, cols - 1);
    const int r =
        std::clamp(static_cast<int>(kp.y * static_cast<float>(rows) / image_height), 0, rows - 1);
    hit[static_cast<std::size_t>(r * cols + c)] = 1;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), 1)) /
         static_cast<double>(cols * rows);
}

}  // namespace coloc::slam::features
